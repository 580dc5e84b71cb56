"""A mesh whose size suggests the wrong ``units`` gets a hint."""

from __future__ import annotations

import pytest

from deformsim.spec.model import load_spec, units_hint
from tests.util import CARTON_SPEC, cli


@pytest.fixture
def spec_in(tmp_path):
    def make(units: str, size: str = ""):
        path = tmp_path / f"spec-{units}.yaml"
        path.write_text(CARTON_SPEC.read_text().replace("units: mm", f"units: {units}{size}"))
        return path
    return make


def test_hint_names_the_likely_unit(spec_in):
    as_metres = load_spec(spec_in("m"))
    hint = units_hint([70.0, 70.0, 190.0], as_metres)  # a carton in mm read as metres
    assert "units: mm" in hint and "70 x 70 x 190 mm" in hint
    assert units_hint([0.07, 0.07, 0.19], load_spec(spec_in("mm"))) is None
    assert units_hint([70.0, 70.0, 190.0], load_spec(spec_in("m", "\nsize: 0.2"))) is None  # size rescales
    assert "units: m " in units_hint([7e-5, 7e-5, 1.9e-4], load_spec(spec_in("mm")))  # metres read as mm


def test_generate_warns_before_rendering(monkeypatch, tmp_path, spec_in):
    from deformsim.config import load_config
    from deformsim.generate import stage
    from tests.generate.fakes import use_fakes

    use_fakes(monkeypatch, probe_size=(70.0, 70.0, 190.0))
    warnings = []
    monkeypatch.setattr(stage.log, "warning", lambda msg, *args: warnings.append(msg % args))
    mesh = tmp_path / "carton.stl"
    mesh.write_bytes(b"solid x\n")
    stage.prepare(load_config("quick", {"object.mesh": mesh, "object.spec": spec_in("m")}), tmp_path / "out")
    assert len(warnings) == 1 and "set units: mm" in warnings[0]


@pytest.mark.blender
def test_spec_check_hints_at_a_mesh_1000x_too_large(carton, spec_in):
    proc = cli("spec", "check", str(spec_in("m")), "--object", str(carton))
    assert proc.returncode == 0, proc.stderr
    assert "hint:" in proc.stderr and "set units: mm" in " ".join(proc.stderr.split())
    proc = cli("spec", "check", str(CARTON_SPEC), "--object", str(carton))
    assert proc.returncode == 0 and "hint" not in proc.stderr
