"""pose.mode drop, the pure side: its draws come from a stream of their own, tilt mode draws what it drew before."""

import hashlib
import json

import numpy as np
import pytest

from deformsim.config import load_config
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import rows_for
from deformsim.dataset.rendered import Rendered
from deformsim.sampling import SampleParams, sample_params
from deformsim.sampling.draws import draw_drop
from deformsim.sampling.features import DROP
from deformsim.sampling.streams import generator
from deformsim.spec.model import load_spec

HDRIS = ["city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset"]
# SampleParams' fields before drop mode (and area lights) existed, and the sha256 of samples 0-59 (seed 11) of the
# quick and paper presets as sample_params drew them then (commit before issue 13): tilt mode must not move.
OLD_FIELDS = ("index", "seed", "label", "families", "keys", "displacement", "seal", "tab", "hdri", "hdri_rotation",
              "hdri_strength", "cameras", "design", "material", "extent", "pose_tilt", "pose_axis", "bank", "bank_amount")
BEFORE = {"quick": "d49b59b1fe96912354766d2f46f8c1fc4dffb2769e31a4998d39e4632e436573",
          "paper": "54e555305eb238cfe2e34a22dfd7e822b8ec7a9ec2a118670f2fcda55d103f32"}


def _up_angle(q) -> float:
    w, x, y, z = q
    return float(np.degrees(np.arccos(np.clip(1 - 2 * (x * x + y * y), -1, 1))))


@pytest.mark.parametrize("preset", sorted(BEFORE))
def test_tilt_mode_draws_what_it_drew_before_drop_mode(preset):
    cfg, spec = load_config(preset), load_spec()
    assert cfg.pose.mode == "tilt"
    draws = []
    for i in range(60):
        d = sample_params(i, 11, cfg, spec, HDRIS).to_dict()
        assert d["drop_rotation"] == ()
        draws.append({k: d[k] for k in OLD_FIELDS})
    assert hashlib.sha256(json.dumps(draws, sort_keys=True).encode()).hexdigest() == BEFORE[preset]


def test_drop_mode_changes_only_the_pose():
    spec = load_spec()
    tilt, drop = load_config("quick"), load_config("quick", {"pose.mode": "drop"})
    for i in range(100):
        a, b = sample_params(i, 3, tilt, spec, HDRIS).to_dict(), sample_params(i, 3, drop, spec, HDRIS).to_dict()
        assert b["pose_tilt"] == b["pose_axis"] == 0.0 and len(b["drop_rotation"]) == 4
        for k in ("pose_tilt", "pose_axis", "drop_rotation"):
            a.pop(k), b.pop(k)
        assert a == b


def test_drop_rotation_is_a_deterministic_unit_quaternion_per_seed_and_index():
    cfg, spec = load_config("quick", {"pose.mode": "drop"}), load_spec()
    a = [sample_params(i, 7, cfg, spec, HDRIS) for i in range(50)]
    backwards = [sample_params(i, 7, cfg, spec, HDRIS).drop_rotation for i in reversed(range(50))]
    assert [p.drop_rotation for p in a] == backwards[::-1]
    assert [p.drop_rotation for p in a] != [sample_params(i, 8, cfg, spec, HDRIS).drop_rotation for i in range(50)]
    for p in a:
        assert isinstance(p.drop_rotation, tuple) and abs(np.linalg.norm(p.drop_rotation) - 1) < 1e-12
        assert p.drop_rotation[0] >= 0
        back = SampleParams.from_dict(json.loads(json.dumps(p.to_dict())))  # as the worker receives it
        assert back == p and isinstance(back.drop_rotation, tuple)


def test_drop_upright_share_starts_standing_on_an_end():
    standing = [_up_angle(draw_drop(generator(DROP.stream, 3, i), 1.0)) for i in range(500)]
    assert all(a <= 15 + 1e-9 or a >= 165 - 1e-9 for a in standing)
    assert 0.4 < np.mean([a <= 15 for a in standing]) < 0.6  # either end
    uniform = np.array([_up_angle(draw_drop(generator(DROP.stream, 3, i), 0.0)) for i in range(4000)])
    assert abs(np.mean(np.cos(np.radians(uniform)))) < 0.03 and abs(np.mean(uniform < 60) - 0.25) < 0.03  # uniform


def test_manifest_records_the_drop_columns_only_in_drop_mode(tmp_path):
    spec, layout = load_spec(), Layout(tmp_path)
    p = sample_params(0, 1, load_config("quick"), spec, HDRIS)
    row = rows_for(p, layout, Rendered(p.index, [1.0] * 4))[0]
    assert not any(k.startswith(("drop_", "rest_")) for k in row)
    q = sample_params(0, 1, load_config("quick", {"pose.mode": "drop"}), spec, HDRIS)
    pose = {"rest_qw": 1.0, "rest_qx": 0.0, "rest_qy": 0.0, "rest_qz": 0.0, "rest_tilt": 0.0, "drop_frames": 30,
            "drop_settled": True}
    row = rows_for(q, layout, Rendered(q.index, [1.0] * 4, sample_columns=pose))[0]
    assert [row[f"drop_q{a}"] for a in "wxyz"] == list(q.drop_rotation)
    assert row["rest_tilt"] == 0.0 and row["drop_settled"] is True


def test_tilt_mode_keeps_its_dataset_identity():
    from deformsim.generate.identity import data_name, data_settings

    assert data_settings(load_config("quick"))["pose"] == {"tilt": [0.0, 90.0]}  # as before the drop settings
    assert data_settings(load_config("quick", {"pose.drop_frames": 50}))["pose"] == {"tilt": [0.0, 90.0]}
    assert data_name(load_config("quick", {"pose.mode": "drop"})) != data_name(load_config("quick"))
    assert data_name(load_config("quick", {"pose.mode": "drop", "pose.drop_upright": 0.5})) != data_name(
        load_config("quick", {"pose.mode": "drop"}))
