"""Where a bank lives and what it holds.

A bank is a folder ``cache_dir()/banks/SPEC-KEY`` with ``bank.npz`` (``positions``: float32 (entries, vertices,
3), the render mesh's object-space vertex positions per entry; ``names``: ``SCENARIO/I``) and ``bank.json``
(each entry's drawn parameters and simulation statistics). ``KEY`` digests everything the bake depends on:
the mesh bytes, the spec's part and simulation settings and :data:`BAKE_REVISION`, so a changed scenario
re-bakes and a changed lattice family does not. A folder only appears once its bank is complete.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deformsim.identity import digest, file_digest
from deformsim.outputs import cache_dir
from deformsim.spec.model import Spec
from deformsim.spec.simulation import entry_names

BAKE_REVISION = 2  # bump when the simulation code changes what a bake produces


def bank_key(spec: Spec, mesh: str | Path | None) -> str:
    """The digest of a bank's inputs (see the module docstring)."""
    if spec.simulation is None:
        raise ValueError(f"spec '{spec.name}' declares no simulation")
    return digest({
        "revision": BAKE_REVISION,
        "mesh": file_digest(mesh) if mesh is not None else None,
        "part": spec.model_dump(mode="json", include={"builtin", "units", "size", "up_axis"}),
        "simulation": spec.simulation.model_dump(mode="json"),
    })


def bank_dir(spec: Spec, mesh: str | Path | None) -> Path:
    return cache_dir() / "banks" / f"{re.sub(r'[^A-Za-z0-9_.-]+', '_', spec.name)}-{bank_key(spec, mesh)}"


@dataclass
class Bank:
    names: list[str]
    positions: np.ndarray  # float32 (entries, vertices, 3)
    entries: list[dict]  # per entry: name, variant, stats

    def stats(self) -> dict[str, float]:
        secs = [e["stats"]["seconds"] for e in self.entries]
        return {"entries": len(secs), "seconds_total": round(sum(secs), 2),
                "seconds_per_entry": round(sum(secs) / max(len(secs), 1), 2)}


def is_complete(path: Path, spec: Spec) -> bool:
    return (path / "bank.npz").is_file() and (path / "bank.json").is_file() and read_names(path) == entry_names(spec.simulation)


def read_names(path: Path) -> list[str]:
    return [e["name"] for e in json.loads((path / "bank.json").read_text())["entries"]]


def load_bank(path: str | Path) -> Bank:
    path = Path(path)
    meta = json.loads((path / "bank.json").read_text())
    with np.load(path / "bank.npz", allow_pickle=False) as z:
        return Bank(names=[str(n) for n in z["names"]], positions=z["positions"], entries=meta["entries"])
