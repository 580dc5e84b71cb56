"""The render-feature seam: the registry's order, and a worker sets up exactly the features its config turns on."""

from __future__ import annotations

import json

import pytest

from deformsim.config import load_config
from tests.blender.conftest import run_blender

pytestmark = pytest.mark.blender

ALL = {"render.resolution": 32, "render.dense": True, "render.shadow": True, "render.surface": {},
       "lighting.area_lights.count": [1, 2], "pose.mode": "drop", "lighting.sun": {}}


def test_worker_sets_up_the_features_its_config_turns_on(tmp_path):
    configs = {"quick": load_config("quick", {"render.resolution": 32}),
               "none": load_config("quick", {"render.resolution": 32, "render.dense": False}),
               "all": load_config("quick", ALL)}
    out = run_blender(f"""
import json
import bpy
from deformsim.blender import worker
from deformsim.blender.features import FEATURES

out = {{"registry": [f.__name__ for f in FEATURES]}}
for name, cfg in json.loads({json.dumps({k: c.model_dump(mode="json") for k, c in configs.items()})!r}).items():
    ctx, _, _ = worker.setup({{"config": cfg, "spec_path": None, "out": {str(tmp_path)!r}}})
    out[name] = [type(f).__name__ for f in ctx.features]
    out[name + "_kinds"] = [k for f in ctx.features for k in f.kinds]
    out[name + "_planes"] = sorted(o.name for o in bpy.data.objects if o.name.startswith("Deformsim") and o.type == "MESH")
    out[name + "_sun"] = [o.data.type for o in bpy.data.objects if o.name == "DeformsimSun"]
print(json.dumps(out))
""")
    assert out["registry"] == ["AreaLights", "Drop", "Dense", "Shadow", "Surface", "Sun"]
    assert out["quick"] == ["Dense"] and out["none"] == [] and out["all"] == out["registry"]
    assert out["all_kinds"] == ["mask", "depth", "normal", "deform", "region", "shadow", "surface"]
    assert out["none_planes"] == [] and out["all_planes"] == ["DeformsimShadowCatcher", "DeformsimSurface"]
    assert out["quick_sun"] == [] and out["all_sun"] == ["SUN"]
