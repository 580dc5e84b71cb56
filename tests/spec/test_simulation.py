"""The spec's simulation section: one-line errors for bad scenarios, fixed variants per scenario."""

from __future__ import annotations

import pytest

from deformsim.errors import UserError
from deformsim.spec.model import load_spec
from deformsim.spec.simulation import Scenario, entry_names, variants

BASE = """
name: part
builtin: can
families:
  - name: crush
    keys: [{name: k, ops: [{op: compress, amount: 0.5}]}]
"""


def _spec(tmp_path, simulation: str):
    path = tmp_path / "spec.yaml"
    path.write_text(BASE + simulation)
    return load_spec(path)


def test_builtin_can_declares_four_scenarios():
    spec = load_spec()
    assert spec.scenario_names == ["stamped", "squashed", "dented", "crumpled"]
    assert len(entry_names(spec.simulation)) == sum(s.variants for s in spec.simulation.scenarios)


@pytest.mark.parametrize("scenario, words", [
    ("{name: s, kind: melt}", "kind"),
    ("{name: s, kind: axial_crush, travel: [0.5, 1.2]}", "travel [0.5, 1.2] must stay below 1"),
    ("{name: s, kind: axial_crush, tilt: [0, 80]}", "tilt range [0.0, 80.0] goes above 45"),
    ("{name: s, kind: crumple, directions: [1, 3]}", "directions [1, 3]"),
    ("{name: s, kind: axial_crush, variants: 0}", "variants"),
    ("{name: crush, kind: axial_crush}", "scenario names that are also family names: crush"),
])
def test_bad_scenario_is_one_line_naming_it(tmp_path, scenario, words):
    with pytest.raises(UserError) as exc:
        _spec(tmp_path, f"simulation:\n  scenarios:\n    - {scenario}\n")
    msg = str(exc.value)
    assert "\n" not in msg and words in msg and "scenario" in msg


def test_duplicate_scenarios_and_empty_list_are_refused(tmp_path):
    with pytest.raises(UserError, match="duplicate scenario names: s"):
        _spec(tmp_path, "simulation:\n  scenarios: [{name: s, kind: crumple}, {name: s, kind: crumple}]\n")
    with pytest.raises(UserError, match="no scenarios"):
        _spec(tmp_path, "simulation:\n  scenarios: []\n")


def test_variants_are_fixed_by_the_scenario_and_inside_its_ranges():
    sc = Scenario(name="s", kind="axial_crush", variants=5, travel=(0.2, 0.4), tilt=(5, 10))
    a, b = variants(sc), variants(sc)
    assert a == b and len(a) == 5
    assert all(0.2 <= v.travel <= 0.4 and 5 <= v.tilt <= 10 for v in a)
    assert len({v.travel for v in a}) == 5  # different travels
    other = variants(Scenario(name="t", kind="axial_crush", variants=5, travel=(0.2, 0.4)))
    assert [v.travel for v in other] != [v.travel for v in a]
