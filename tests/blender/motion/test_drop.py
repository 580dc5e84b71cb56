"""pose.mode drop: the deformed can falls onto the ground with Blender's rigid-body solver and rests on it."""

from __future__ import annotations

import json

import pytest

from tests.blender.conftest import TINY_RENDER, run_blender

pytestmark = pytest.mark.blender

TOLERANCE = 1e-4  # m: 0.1 mm at can scale (the part is placed on the ground analytically after the simulation)


@pytest.fixture(scope="module")
def drops(tmp_path_factory):
    """One worker scene: 8 drop-mode samples (half start standing) dropped, two dropped twice, one rendered."""
    out = tmp_path_factory.mktemp("drop")
    overrides = {**TINY_RENDER, "pose.mode": "drop", "pose.drop_upright": 0.5,
                 "camera.azimuth_quadrants": [[20, 70], [200, 250]]}
    return run_blender(f"""
        import json, time
        import bpy, numpy as np
        from deformsim.blender.motion import drop
        from deformsim.blender.passes.render import apply_state, render_sample
        from deformsim.blender.worker import setup
        from deformsim.config import load_config
        from deformsim.dataset.layout import Layout, image_id
        from deformsim.hdri import list_hdris
        from deformsim.sampling import sample_params
        from deformsim.spec.model import load_spec
        from PIL import Image

        cfg = load_config("quick", {json.dumps(overrides)})
        ctx, layout, ready = setup({{"config": cfg.model_dump(mode="json"), "spec_path": None, "out": "{out}"}})
        dropper = next(f for f in ctx.features if isinstance(f, drop.Drop))
        spec, hdris = load_spec(None), list_hdris(None)
        counts = lambda: [len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections)]
        before = counts()
        samples = []
        for i in range(8):
            p = sample_params(i, 4, cfg, spec, hdris)
            target = apply_state(ctx, p)
            bpy.context.view_layer.update()
            co, _ = drop.evaluated_local(ctx.obj)
            m = np.array(ctx.obj.matrix_world)
            z = (co @ m[:3, :3].T + m[:3, 3])[:, 2]
            samples.append({{"label": p.label, "min_z": float(z.min()), "max_z": float(z.max()), "target": target,
                             "ground": ctx.ground, "seconds": dropper.rest.seconds, **dropper.sample_columns()}})
        again = []
        for i in (1, 2):
            apply_state(ctx, sample_params(i, 4, cfg, spec, hdris))
            again.append(list(dropper.rest.rotation))
        p = sample_params(2, 4, cfg, spec, hdris)
        rendered = render_sample(ctx, p, layout)
        alpha = [np.array(Image.open(layout.image("rgba", image_id(2, c))))[..., 3] for c in range(2)]
        print(json.dumps({{"samples": samples, "again": again, "before": before, "after": counts(),
                           "rigidbody_world": bpy.context.scene.rigidbody_world is not None,
                           "rendered_columns": rendered.sample_columns == dropper.sample_columns(),
                           "coverage": [float((a > 0).mean()) for a in alpha],
                           "border": [int(max(a[0].max(), a[-1].max(), a[:, 0].max(), a[:, -1].max())) for a in alpha]}}))
    """, timeout=240)


def test_dropped_part_rests_on_the_ground(drops):
    for s in drops["samples"]:
        assert abs(s["min_z"] - s["ground"]) < TOLERANCE, s  # touches the plane, nothing below it
        assert abs(s["target"][2] - (s["min_z"] + s["max_z"]) / 2) < TOLERANCE  # cameras aim at the resting part
        assert s["seconds"] < 5


def test_drops_rest_in_varied_poses(drops):
    tilts = [s["rest_tilt"] for s in drops["samples"]]
    assert any(t < 20 or t > 160 for t in tilts), tilts  # standing on an end
    assert any(60 < t < 120 for t in tilts), tilts  # on its side
    assert len({round(s["rest_qw"], 3) for s in drops["samples"]}) == len(tilts)


def test_drop_is_deterministic_and_leaves_nothing_behind(drops):
    first = [[drops["samples"][i][f"rest_q{a}"] for a in "wxyz"] for i in (1, 2)]
    for a, b in zip(first, drops["again"]):
        assert max(abs(x - y) for x, y in zip(a, b)) < 1e-5
    assert drops["after"] == drops["before"]  # temporary bodies, meshes and the rigid-body collection are gone
    assert not drops["rigidbody_world"]


def test_reply_carries_the_resting_pose(drops):
    assert drops["rendered_columns"]


def test_dropped_part_is_framed(drops):
    assert all(0.02 < c < 0.6 for c in drops["coverage"]), drops["coverage"]
    assert drops["border"] == [0, 0], json.dumps(drops["border"])
