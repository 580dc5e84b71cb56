"""The worker's scene set-up (in a Blender subprocess)."""

from __future__ import annotations

import pytest

from tests.blender.conftest import run_blender

pytestmark = pytest.mark.blender


def test_builtin_can_keeps_its_aluminium_lid_and_bottom(tmp_path):
    out = run_blender(f"""
        import json
        import numpy as np
        from deformsim.blender.worker import setup
        from deformsim.config import load_config
        cfg = load_config("quick", {{"render.resolution": 32, "render.samples": 1}})
        ctx, _, _ = setup({{"config": cfg.model_dump(mode="json"), "spec_path": None, "out": "{tmp_path}"}})
        me = ctx.obj.data
        idx = np.empty(len(me.polygons), np.int32)
        me.polygons.foreach_get("material_index", idx)
        print(json.dumps({{"slots": [m.name for m in me.materials], "counts": np.bincount(idx, minlength=2).tolist()}}))
    """)
    assert out["slots"] == ["Label", "Aluminium"]
    assert min(out["counts"]) > 500  # the side wall printed, lid, neck and bottom bare aluminium
