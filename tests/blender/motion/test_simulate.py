"""The simulated deformation bank: a real cloth crush in Blender, baked once into the cache and rendered."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from deformsim.bank.stage import bake
from deformsim.bank.store import load_bank
from deformsim.errors import UserError
from deformsim.spec.model import load_spec

pytestmark = pytest.mark.blender

TRAVEL = 0.4
SPEC = """
name: tiny-can
builtin: can
families:
  - name: crush
    keys: [{{name: k, ops: [{{op: compress, amount: 0.5}}]}}]
openings: {{seal: Seal, tab: Tab}}
simulation:
  resolution: 24
  frames: {frames}
  quality: {quality}
  bending: 50
  scenarios:
    - {{name: stamped, kind: axial_crush, variants: 1, travel: [{travel}, {travel}]}}
"""


def _spec(tmp_path, name="spec.yaml", frames=20, quality=5, travel=TRAVEL):
    path = tmp_path / name
    path.write_text(SPEC.format(frames=frames, quality=quality, travel=travel))
    return path


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bank")
    mp = pytest.MonkeyPatch()
    mp.setenv("DEFORMSIM_CACHE", str(tmp / "cache"))
    path = _spec(tmp)
    t0 = time.perf_counter()
    bank = bake(load_spec(path), path, None, progress=False)
    yield tmp, path, bank, time.perf_counter() - t0
    mp.undo()


def test_axial_crush_lowers_the_can_by_the_commanded_travel(baked):
    _, _, path, _ = baked
    bank = load_bank(path)
    assert bank.names == ["stamped/0"]
    stats = bank.entries[0]["stats"]
    # the plate stops TRAVEL of the height below the top; the shell springs back or folds past it a little
    assert abs(stats["height_ratio"] - (1 - TRAVEL)) < 0.1, stats
    z = bank.positions[0][:, 2]
    assert z.min() > -0.004  # the ground held: nothing pushed through the floor


def test_crushed_shell_is_not_exploded_or_self_intersecting(baked):
    _, _, path, _ = baked
    stats = load_bank(path).entries[0]["stats"]
    assert stats["stretch"] < 4.0  # a plain crush stretches no shell edge beyond 4x its rest length
    assert 0.6 < stats["area_ratio"] < 1.15  # folded, not stretched or collapsed to nothing
    assert stats["intersecting_faces"] < 0.02  # self-collision keeps folds apart (tolerance: 2 % of the faces)
    co = load_bank(path).positions[0]
    assert np.isfinite(co).all() and np.ptp(co[:, :2], axis=0).max() < 0.066 * 1.8  # bulges, stays can-sized


def test_cached_bank_is_reused_and_a_changed_scenario_rebakes(baked, monkeypatch):
    tmp, spec_path, path, first_seconds = baked
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp / "cache"))
    stamp = (path / "bank.npz").stat().st_mtime_ns
    t0 = time.perf_counter()
    assert bake(load_spec(spec_path), spec_path, None, progress=False) == path
    assert time.perf_counter() - t0 < min(1.0, first_seconds / 4)
    assert (path / "bank.npz").stat().st_mtime_ns == stamp
    from deformsim import Engine

    assert Engine("quick", {"object.spec": spec_path}).bake() == path  # the Python API finds the same bank
    other = _spec(tmp, "other.yaml", travel=0.3)
    again = bake(load_spec(other), other, None, progress=False)
    assert again != path and again.is_dir() and path.is_dir()
    assert load_bank(again).entries[0]["stats"]["height_ratio"] > load_bank(path).entries[0]["stats"]["height_ratio"]


def test_diverging_simulation_fails_with_one_line_and_caches_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path / "cache"))
    path = _spec(tmp_path, frames=4, quality=1, travel=0.9)
    with pytest.raises(UserError) as exc:
        bake(load_spec(path), path, None, progress=False)
    msg = str(exc.value)
    assert "\n" not in msg and "scenario 'stamped'" in msg and "nothing was cached" in msg
    assert not any((tmp_path / "cache" / "banks").iterdir())


def test_generate_renders_bank_entries_and_records_them(baked, tmp_path, monkeypatch):
    from deformsim.config import load_config
    from deformsim.generate.stage import generate

    tmp, spec_path, _, _ = baked
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp / "cache"))
    cfg = load_config("quick", {"object.spec": spec_path, "generate.n": 8, "generate.workers": 1, "generate.preview": 0,
                                "render.resolution": 48, "render.samples": 2, "render.dense": False,
                                "deform.sources.lattice": 0, "deform.sources.bank": 1, "deform.bank_amount": [1, 1],
                                "camera.radius": [0.4, 0.4], "camera.polar": [60, 60], "pose.tilt": [0, 0]})
    generate(cfg, tmp_path / "data", progress=False)
    import pandas as pd

    m = pd.read_parquet(tmp_path / "data" / "manifest.parquet")
    deformed = m[m.label == "deformed"]
    assert (deformed.bank == "stamped/0").all() and (deformed.bank_amount == 1).all()
    assert (m[m.label == "intact"].bank == "").all()
    assert (deformed.filter(like="key_") == 0).all().all()  # bank only: no lattice key
    from PIL import Image

    def rows(path):  # image rows the can covers
        return int((np.asarray(Image.open(tmp_path / "data" / path))[..., 3] > 0).any(axis=1).sum())

    intact = m[m.label == "intact"].iloc[0]
    crushed = deformed[deformed.camera == intact.camera].iloc[0]
    assert rows(crushed.rgba) < 0.85 * rows(intact.rgba), json.dumps([intact.rgba, crushed.rgba])
