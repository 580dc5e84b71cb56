"""`deformsim checks` and `--version`: what deformsim runs on (Python, Blender's bpy, torch and its device, Ray) and
where its offline weights are. Versions come from the installed packages' records: bpy is asked in a subprocess,
so the command line never imports Blender."""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata

import typer

from deformsim.cli.common import console, fail_cleanly
from deformsim.version import __version__

BLENDER_S = 60  # longest wait for the subprocess that imports bpy


def installed(dist: str) -> str:
    """The installed version of package ``dist``, or ``not installed``."""
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


def version_line() -> str:
    """``deformsim X``, then a line with the versions of Python and the packages deformsim runs on."""
    python = ".".join(map(str, sys.version_info[:3]))
    parts = ", ".join(f"{name} {installed(name)}" for name in ("bpy", "torch", "ray"))
    return f"deformsim {__version__}\nPython {python}, {parts}; deformsim checks adds Blender, the devices and the weights"


def _blender() -> str:
    """Blender's version as the bpy module reports it, asked in a subprocess (importing bpy takes seconds)."""
    code = "import bpy; print(bpy.app.version_string)"
    try:
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=BLENDER_S)
    except subprocess.TimeoutExpired:
        return f"bpy did not answer in {BLENDER_S} s"
    lines = done.stdout.strip().splitlines()
    if done.returncode or not lines:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return f"bpy does not import: {last}"
    return f"Blender {lines[-1]}"


def _torch() -> str:
    """torch's version and the device training picks (``train.device: auto``)."""
    try:
        import torch
    except ImportError:
        return "not installed"
    if torch.cuda.is_available():
        device = f"cuda ({torch.cuda.get_device_name(0)}, {torch.cuda.device_count()} GPU)"
    else:
        device = f"cpu (no CUDA device; torch built with CUDA {torch.version.cuda})" if torch.version.cuda else \
            "cpu (a torch built without CUDA)"
    return f"{torch.__version__}, training device: {device}"


def _weights() -> list[str]:
    """Per backbone with offline ImageNet weights: the installed file, or the command that installs it."""
    from deformsim.learn.backbones import BACKBONES

    lines = []
    for name, bb in BACKBONES.items():
        if bb.offline is not None:
            path = bb.offline.locate()
            lines.append(f"{name}: {path}" if path is not None else f"{name}: missing ({bb.offline.install})")
    return lines


def check_lines() -> list[str]:
    """Every line of ``deformsim checks``."""
    from deformsim.outputs import cache_dir

    return [
        f"deformsim {__version__}",
        f"Python {sys.version.split()[0]} ({sys.executable})",
        f"bpy {installed('bpy')}: {_blender()}",
        f"torch {_torch()}",
        f"ray {installed('ray')}",
        "offline ImageNet weights (train.weights imagenet falls back to them, offline uses only them):",
        *(f"  {line}" for line in _weights()),
        f"cache (converted weights, features, banks): {cache_dir()}",
    ]


def register(app: typer.Typer) -> None:
    @app.command("checks")
    @fail_cleanly
    def checks() -> None:
        """Print the versions of Python, Blender (bpy), torch with its device and Ray, and where the offline weights
        and the cache are: what to paste into a bug report."""
        for line in check_lines():
            console.print(line, highlight=False, markup=False)
