"""Rendering through the worker protocol: silhouettes, determinism, exact alpha, background variants."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset.layout import Layout, image_id
from deformsim.generate.worker_client import WorkerProcess
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import TINY_RENDER, run_blender

pytestmark = pytest.mark.blender

CAMERAS = [(20, 70), (200, 250)]
KINDS = ("rgba", "black", "green")


def _config(**extra):
    return load_config("quick", {**TINY_RENDER, "camera.azimuth_quadrants": CAMERAS, **extra})


def _read(layout: Layout, kind: str, index: int, cam: int) -> np.ndarray:
    return np.array(Image.open(layout.image(kind, image_id(index, cam))))


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """Worker 1 renders intact I, deformed D, a failing sample, D again; worker 2 (Cycles backgrounds) D."""
    cfg = _config()
    spec, hdris = load_spec(None), list_hdris(None)
    d = sample_params(0, 5, cfg, spec, hdris)
    other = sample_params(1, 5, cfg, spec, hdris)
    assert d.deformed
    d = dataclasses.replace(d, keys={**d.keys, "crush_top": 0.6, "fold_x": 0.4})  # clearly deformed
    i = dataclasses.replace(d, index=1, label="intact", families=(), keys=dict.fromkeys(d.keys, 0.0),
                            displacement=dict.fromkeys(d.displacement, 0.0), design=other.design)
    bad = dataclasses.replace(d, index=2, hdri="no-such-hdri")
    root = tmp_path_factory.mktemp("render")
    one, two = Layout(root / "one"), Layout(root / "two")
    facts = {"d": d, "one": one, "two": two, "first": {}}
    w = WorkerProcess(root / "w1.log", threads=2)
    try:
        facts["ready"] = w.start({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(one.root)})
        facts["replies"] = [w.render(i.to_dict()), w.render(d.to_dict())]
        for kind in KINDS:
            for c in range(len(CAMERAS)):
                facts["first"][kind, c] = one.image(kind, image_id(0, c)).read_bytes()
        facts["replies"] += [w.render(bad.to_dict()), w.render(d.to_dict())]
    finally:
        w.close()
    w2 = WorkerProcess(root / "w2.log", threads=2)
    try:
        cfg2 = _config(**{"render.render_backgrounds": True})
        w2.start({"config": cfg2.model_dump(mode="json"), "spec_path": None, "out": str(two.root)})
        facts["replies"].append(w2.render(d.to_dict()))
    finally:
        w2.close()
    return facts


def test_ready_reply_describes_the_scene(renders):
    ready = renders["ready"]
    assert ready["device"].startswith("CPU")
    assert ready["camera_scale"] == 1.0
    assert np.allclose(ready["object_size"], [0.066, 0.066, 0.122], atol=0.004)


def test_replies_and_failed_sample_keeps_worker_alive(renders):
    r = renders["replies"]
    assert r[0]["done"] == 1 and r[1]["done"] == 0 and r[3]["done"] == 0 and r[4]["done"] == 0
    assert r[2]["error"] == 2 and "no-such-hdri" in r[2]["message"]
    assert all(len(x["render_seconds"]) == len(CAMERAS) and min(x["render_seconds"]) > 0 for x in r if "done" in x)


def test_deformed_silhouette_differs_from_intact(renders):
    one = renders["one"]
    for c in range(len(CAMERAS)):
        d = _read(one, "rgba", 0, c)[..., 3] > 127
        i = _read(one, "rgba", 1, c)[..., 3] > 127
        iou = (d & i).sum() / (d | i).sum()
        assert i.sum() > 100, "the intact can is visible"
        assert iou < 0.97, f"camera {c}: deformed and intact silhouettes overlap too much (IoU {iou:.3f})"


def test_same_sample_renders_byte_identical(renders):
    one, two = renders["one"], renders["two"]
    for (kind, c), first in renders["first"].items():
        assert one.image(kind, image_id(0, c)).read_bytes() == first, f"{kind} camera {c} changed on re-render"
        # a fresh worker (which rendered nothing before) gives the same exact-alpha image
        assert two.image("rgba", image_id(0, c)).read_bytes() == first if kind == "rgba" else True


def test_alpha_is_exact_and_variants_are_composited(renders):
    one = renders["one"]
    for index, c in [(i, c) for i in (0, 1) for c in range(len(CAMERAS))]:
        rgba = _read(one, "rgba", index, c).astype(int)
        a = rgba[..., 3:]
        assert rgba.shape[-1] == 4 and (a[:4, :4] == 0).all() and (a == 255).sum() > 40
        assert ((a > 0) & (a < 255)).sum() > 0, "antialiased edges keep fractional alpha"
        for kind, color in (("black", (0, 0, 0)), ("green", (0, 255, 0))):
            img = _read(one, kind, index, c).astype(int)
            want = (rgba[..., :3] * a + np.array(color) * (255 - a) + 127) // 255
            assert np.array_equal(img, want)
            assert (img[a[..., 0] == 0] == color).all()


def test_cycles_backgrounds_match_composited(renders):
    one, two = renders["one"], renders["two"]
    for c in range(len(CAMERAS)):
        for kind, color in (("black", (0, 0, 0)), ("green", (0, 255, 0))):
            rendered = _read(two, kind, 0, c).astype(int)
            composited = _read(one, kind, 0, c).astype(int)
            assert (rendered[:4, :4] == color).all(), f"{kind}: camera rays see the flat colour"
            diff = np.abs(rendered - composited).mean()
            assert diff < 3.0, f"{kind} camera {c}: rendered differs from composited by {diff:.2f}"


def test_world_hdris_match_bpy_free_listing(tmp_path):
    (tmp_path / "b.hdr").write_bytes(b"x")
    (tmp_path / "a.exr").write_bytes(b"x")
    out = run_blender(
        f"""
import json, bpy
from deformsim.blender.scene.world import World
paths = {{key: sorted(World(bpy.context.scene, d).paths) for key, d in (("default", None), ("user", {str(tmp_path)!r}))}}
print(json.dumps(paths))
"""
    )
    assert out["default"] == list_hdris(None)
    assert out["user"] == list_hdris(tmp_path) == ["a", "b"]
