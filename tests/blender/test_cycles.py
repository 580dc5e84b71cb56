"""Cycles settings: each render setting reaches Cycles, the defaults are today's, a worker switches them in place."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from deformsim.config import RenderConfig, load_config
from deformsim.dataset.layout import Layout, image_id
from deformsim.generate.worker_client import WorkerProcess
from deformsim.hdri import list_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.blender.conftest import TINY_RENDER, run_blender

pytestmark = pytest.mark.blender

READ = """
def read(cy):
    names = ["use_adaptive_sampling", "adaptive_threshold", "adaptive_min_samples", "max_bounces", "diffuse_bounces",
             "glossy_bounces", "transmission_bounces", "transparent_max_bounces", "volume_bounces", "caustics_reflective",
             "caustics_refractive", "sample_clamp_direct", "sample_clamp_indirect", "use_denoising",
             "denoising_input_passes", "denoising_prefilter", "denoising_quality", "tile_size", "samples"]
    world = bpy.context.scene.world.cycles
    return {n: round(v, 6) if isinstance(v, float) else v for n, v in ((n, getattr(cy, n)) for n in names)} | {
        "world_map": [world.sampling_method, world.sample_map_resolution]}
"""

CUSTOM = {"samples": 7, "adaptive": True, "adaptive_threshold": 0.05, "adaptive_min_samples": 3, "max_bounces": 9,
          "diffuse_bounces": 1, "glossy_bounces": 2, "transmission_bounces": 3, "transparent_bounces": 5, "volume_bounces": 1,
          "caustics_reflective": False, "caustics_refractive": False, "clamp_direct": 4.0, "clamp_indirect": 2.5,
          "denoise_input": "rgb_albedo", "denoise_prefilter": "fast", "denoise_quality": "balanced", "tile_size": 64,
          "world_map": 256}


def test_settings_reach_cycles_and_defaults_are_todays():
    out = run_blender(READ + f"""
import json, bpy
from deformsim.blender.cycles import configure_cycles, reset
from deformsim.config import RenderConfig
reset()
bpy.context.scene.world = bpy.data.worlds.new("HDRI")
cy = bpy.context.scene.cycles
factory = read(cy)
configure_cycles(bpy.context.scene, RenderConfig(device="cpu"))
default = read(cy)
configure_cycles(bpy.context.scene, RenderConfig.model_validate({{"device": "cpu", **json.loads('{json.dumps(CUSTOM)}')}}))
print(json.dumps({{"factory": factory, "default": default, "custom": read(cy)}}))
""")
    factory, default = out["factory"], out["default"]
    # today: fixed samples, adaptive sampling off, 6 bounces, everything else as Blender ships it
    assert default == {**factory, "use_adaptive_sampling": False, "max_bounces": 6, "samples": RenderConfig().samples}
    assert out["custom"] == {
        "samples": 7, "use_adaptive_sampling": True, "adaptive_threshold": 0.05, "adaptive_min_samples": 3,
        "max_bounces": 9, "diffuse_bounces": 1, "glossy_bounces": 2, "transmission_bounces": 3,
        "transparent_max_bounces": 5, "volume_bounces": 1, "caustics_reflective": False, "caustics_refractive": False,
        "sample_clamp_direct": 4.0, "sample_clamp_indirect": 2.5, "use_denoising": True,
        "denoising_input_passes": "RGB_ALBEDO", "denoising_prefilter": "FAST", "denoising_quality": "BALANCED",
        "tile_size": 64, "world_map": ["MANUAL", 256],
    }


def test_worker_switches_settings_in_place(tmp_path):
    cfg = load_config("quick", {**TINY_RENDER, "camera.azimuth_quadrants": [[20, 70]], "render.dense": False})
    p = sample_params(0, 0, cfg, load_spec(None), list_hdris(None))
    layout = Layout(tmp_path / "out")
    w = WorkerProcess(tmp_path / "w.log", threads=2)

    def render() -> np.ndarray:
        assert "done" in w.render(p.to_dict())
        return np.array(Image.open(layout.image("rgba", image_id(0, 0))))

    try:
        w.start({"config": cfg.model_dump(mode="json"), "spec_path": None, "out": str(layout.root)})
        first = render()
        assert "configured" in w.configure({**cfg.render.model_dump(mode="json"), "samples": 1, "denoise": False})
        noisy = render()
        w.configure(cfg.render.model_dump(mode="json"))
        again = render()
    finally:
        w.close()
    assert np.abs(noisy[..., :3].astype(int) - first[..., :3]).mean() > 1  # 1 spp without denoising: visibly noisier
    assert np.array_equal(first, again)  # back to the original settings: the same pixels
