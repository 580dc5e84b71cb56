"""Whether a spec's keys show at the render size (generate/visibility.py): the lattice smoothing and the warning."""

from __future__ import annotations

import numpy as np
import pytest

from deformsim.config import load_config
from deformsim.generate.visibility import box_surface, invisible_keys, key_movement, lattice_displacement
from deformsim.spec.lattice_ops import rest_lattice
from deformsim.spec.model import Spec, load_spec

POINTS = (5, 6, 7)


def test_the_bspline_keeps_constant_and_linear_fields_and_smooths_a_single_point():
    rest = rest_lattice(POINTS)
    at = np.random.default_rng(0).uniform(-0.2, 0.2, (50, 3))  # away from the clamped edges
    assert np.allclose(lattice_displacement(np.tile([1.0, -2.0, 0.5], (len(rest), 1)), POINTS, at), [1.0, -2.0, 0.5])
    assert np.allclose(lattice_displacement(rest * 0.1, POINTS, at), at * 0.1)
    spike = np.zeros_like(rest)
    node = (3 * 6 + 3) * 5 + 2  # u=2, v=3, w=3 in Blender's order (u fastest)
    spike[node] = 1.0
    value = lattice_displacement(spike, POINTS, rest[node][None])[0, 0]
    assert value == pytest.approx((4 / 6) ** 3)  # a cubic B-spline weighs its node 4/6 per axis


def spec_with(depth: float) -> Spec:
    return Spec.model_validate({"name": "t", "units": "mm", "families": [
        {"name": "dent", "keys": [{"name": "knock", "ops": [{"op": "dent", "azimuth": 0, "at": 0.5, "radius": 0.2,
                                                            "depth": depth}]}]}]})


def test_a_shallow_key_is_named_until_the_render_is_big_enough():
    size = (0.07, 0.07, 0.11)
    moved = key_movement(spec_with(0.02), size)["knock"]
    assert 0.0003 < moved < 0.001  # a 0.02 dent at full weight moves a 7 cm part under a millimetre
    line = invisible_keys(load_config("quick"), spec_with(0.02), size)
    assert line is not None and "1 of 1 spec keys" in line and "'knock'" in line and "128 px renders" in line
    assert invisible_keys(load_config("quick", {"render.resolution": 2048}), spec_with(0.02), size) is None
    assert invisible_keys(load_config("quick"), spec_with(0.5), size) is None


def test_the_builtin_cans_keys_show_in_the_presets():
    for preset in ("quick", "paper"):
        assert invisible_keys(load_config(preset), load_spec(None), None) is None


def test_framing_closer_shows_more_pixels():
    spec, size = spec_with(0.05), (0.07, 0.07, 0.11)
    far = invisible_keys(load_config("quick", {"camera.fill": [0.1, 0.2]}), spec, size)
    near = invisible_keys(load_config("quick", {"camera.fill": [0.8, 0.9]}), spec, size)
    assert far is not None and near is None


def test_the_box_points_lie_on_the_parts_box():
    pts = box_surface(0.1, n=5)
    assert np.allclose(np.abs(pts).max(1), 0.5 / 1.2)


def test_generate_warns_with_its_config_and_the_preview_with_the_runs(monkeypatch, tmp_path):
    import yaml

    from deformsim.generate import stage
    from tests.generate.fakes import use_fakes

    use_fakes(monkeypatch, probe_size=(0.07, 0.07, 0.11))
    warnings = []
    monkeypatch.setattr(stage.log, "warning", lambda msg, *args: warnings.append(msg % args))
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump(spec_with(0.02).model_dump(mode="json", exclude_none=True)))
    mesh = tmp_path / "part.stl"
    mesh.write_bytes(b"solid x\n")
    cfg = load_config("quick", {"object.mesh": mesh, "object.spec": spec})
    stage.prepare(cfg, tmp_path / "a")
    assert len(warnings) == 1 and "'knock'" in warnings[0]
    stage.prepare(cfg, tmp_path / "b", seen_with=load_config("quick", {"render.resolution": 2048}))
    assert len(warnings) == 1  # at the run's 2048 px the knock shows
