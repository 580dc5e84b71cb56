"""`deformsim generate`: render a labelled intact/deformed dataset with a pool of Blender workers.

The orchestrator never imports bpy. It validates every input before work starts, draws each sample's
parameters (pure, by index), hands indices to worker processes, writes each finished sample's record
atomically, and consolidates the manifest at the end. Rerunning on the same folder resumes: finished samples
are skipped, so the result is the same as an uninterrupted run's whatever the number of workers.
"""

from __future__ import annotations

import platform
import time
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import yaml

from deformsim.atomic import write_json, write_text
from deformsim.config import Config, dump_config
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import consolidate, read_record
from deformsim.errors import UserError
from deformsim.generate.backend import remove_partial_files
from deformsim.generate.local import run_local
from deformsim.generate.probe import probe_mesh
from deformsim.hdri import list_hdris
from deformsim.log import get_logger
from deformsim.sampling import allowed_families, sample_params
from deformsim.spec.model import Spec, check_mesh_file, load_spec
from deformsim.version import __version__

log = get_logger(__name__)

# Settings that do not change what is rendered: a resumed run may differ in these.
_RUN_ONLY = {"generate": {"n", "workers", "recycle_every", "max_retries", "backend", "address", "gather", "preview"}}
_DATA_SECTIONS = ("object", "camera", "pose", "lighting", "deform", "render", "generate")
_PACKAGES = ("bpy", "numpy", "pydantic", "pandas", "pyarrow", "pillow", "opencv-python-headless", "torch", "torchvision")


@dataclass
class GenerateResult:
    images: int
    rendered: int  # samples rendered by this run (the rest were resumed)
    failed: dict[int, str] = field(default_factory=dict)
    seconds: float = 0.0
    device: str = ""


def data_settings(cfg: Config) -> dict:
    """The part of a config that determines the rendered data."""
    d = cfg.model_dump(mode="json")
    out = {k: d[k] for k in _DATA_SECTIONS}
    for section, keys in _RUN_ONLY.items():
        out[section] = {k: v for k, v in out[section].items() if k not in keys}
    return out


def n_samples(cfg: Config) -> int:
    return cfg.generate.n // len(cfg.camera.azimuth_quadrants)


def prepare(cfg: Config, out: Path) -> tuple[Spec, list[str]]:
    """Every check that can fail on user input, before any work and before touching ``out``."""
    spec = load_spec(cfg.object.spec)
    if cfg.object.mesh is not None:
        check_mesh_file(cfg.object.mesh)
        if spec.builtin:
            raise UserError(f"spec '{spec.name}' is for the built-in {spec.builtin}, not for mesh {cfg.object.mesh}")
        probe_mesh(cfg.object.mesh, cfg.object.spec)
    elif not spec.builtin:
        raise UserError(f"spec '{spec.name}' describes a mesh part: pass the mesh with --object")
    allowed_families(cfg, spec)
    hdris = list_hdris(cfg.lighting.hdri_dir)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UserError(f"output {out} exists and is not a folder")
    layout = Layout(out)
    if layout.config.is_file():
        try:
            old = yaml.safe_load(layout.config.read_text())
            old_settings = data_settings(Config.model_validate(old))
        except Exception:
            raise UserError(f"{out} holds an unreadable {layout.config.name}: use a new output folder") from None
        new = data_settings(cfg)
        if old_settings != new:
            diff = _first_difference(old_settings, new)
            raise UserError(f"{out} was generated with other settings ({diff}): use a new output folder")
    return spec, hdris


def _first_difference(a: dict, b: dict, prefix: str = "") -> str:
    for k in sorted(set(a) | set(b)):
        va, vb = a.get(k), b.get(k)
        if isinstance(va, dict) and isinstance(vb, dict):
            if va != vb:
                return _first_difference(va, vb, f"{prefix}{k}.")
        elif va != vb:
            return f"{prefix}{k}: {va!r} there, {vb!r} now"
    return "?"


def versions() -> dict:
    out = {"deformsim": __version__, "python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def generate(cfg: Config, out: str | Path, progress: bool = True,
             prepared: tuple[Spec, list[str]] | None = None) -> GenerateResult:
    """Render ``cfg.generate.n`` images into ``out`` (resuming what is there) and write the manifest.

    ``prepared`` is what :func:`prepare` returned for the same ``cfg`` and ``out``, when the caller already ran it.
    """
    t0 = time.perf_counter()
    out = Path(out)
    spec, hdris = prepared or prepare(cfg, out)
    layout = Layout(out)
    layout.samples_dir.mkdir(parents=True, exist_ok=True)
    write_text(layout.config, dump_config(cfg))
    write_json(layout.versions, versions())
    remove_partial_files(layout)

    indices = list(range(n_samples(cfg)))
    todo = [i for i in indices if read_record(layout, i) is None]
    params = {i: sample_params(i, cfg.generate.seed, cfg, spec, hdris) for i in todo}
    views = len(cfg.camera.azimuth_quadrants)
    log.info(
        "generate: %d images (%d samples x %d cameras), %d samples to render, %d already done",
        len(indices) * views, len(indices), views, len(todo), len(indices) - len(todo),
    )
    result = GenerateResult(images=len(indices) * views, rendered=0)
    if todo:
        if cfg.generate.backend == "ray":
            from deformsim.generate.ray import run_ray

            failed, device = run_ray(cfg, layout, params, progress)
        else:
            failed, device = run_local(cfg, layout, params, progress)
        result.failed, result.device = failed, device
        result.rendered = len(todo) - len(failed)
    done = [i for i in indices if i not in result.failed]
    consolidate(layout, done)
    if cfg.generate.preview:
        from deformsim.dataset.contact_sheet import contact_sheet

        contact_sheet(layout, cfg.generate.preview, cfg.generate.seed)
    result.images = len(done) * views
    result.seconds = time.perf_counter() - t0
    if result.failed:
        write_json(out / "failures.json", {str(k): v for k, v in result.failed.items()})
    return result
