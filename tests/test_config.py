"""Config and spec validation: one clear line naming the bad value, before any work."""

from pathlib import Path

import pytest

from deformsim.config import list_presets, load_config
from deformsim.errors import UserError
from deformsim.spec import check_mesh_file, load_spec


def test_presets_load_and_paper_has_the_papers_settings():
    assert {"quick", "paper"} <= set(list_presets())
    paper = load_config("paper")
    assert paper.generate.n == 6000 and paper.render.resolution == 512
    assert (paper.train.lr, paper.train.batch_size, paper.train.epochs) == (1e-3, 32, 15)


def test_overrides_apply_and_none_is_ignored():
    cfg = load_config("quick", {"generate.n": 16, "render.resolution": 96, "render.samples": None})
    assert (cfg.generate.n, cfg.render.resolution, cfg.render.samples) == (16, 96, load_config().render.samples)


@pytest.mark.parametrize(
    "overrides, needle",
    [
        ({"render.resolution": 0}, "render.resolution"),
        ({"camera.polar": [70, 50]}, "camera.polar"),
        ({"generate.n": 10}, "multiple of the 4 cameras"),
        ({"deform.families": [4, 2]}, "deform.families"),
    ],
)
def test_bad_values_are_named(overrides, needle):
    with pytest.raises(UserError, match=needle.replace(".", r"\.")):
        load_config("quick", overrides)


def test_missing_and_corrupt_config_files(tmp_path):
    with pytest.raises(UserError, match="not found"):
        load_config(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("render: [1, 2\n")
    with pytest.raises(UserError, match="not valid YAML"):
        load_config(bad)


SPEC = """
name: part
units: mm
families:
  - name: crush
    keys:
      - name: k1
        ops: [{op: compress, amount: 0.3}]
"""


@pytest.mark.parametrize(
    "change, needle",
    [
        (("op: compress", "op: smash"), "unknown operation 'smash'"),
        (("ops: [{op: compress, amount: 0.3}]", "ops: []"), "key has no operations"),
        (("amount: 0.3", "amount: -0.3"), "amount=-0.3 must not be negative"),
        (("amount: 0.3", "amount: 0.3, speed: 2"), "unknown parameter"),
        (("units: mm", "units: furlong"), "unknown unit 'furlong'"),
    ],
)
def test_bad_specs_name_the_problem(tmp_path, change, needle):
    path = tmp_path / "spec.yaml"
    path.write_text(SPEC.replace(*change))
    with pytest.raises(UserError) as err:
        load_spec(path)
    assert needle in str(err.value) and "\n" not in str(err.value)


def test_spec_errors_name_family_and_key(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text(SPEC.replace("op: compress", "op: smash"))
    with pytest.raises(UserError, match="families 'crush'.keys 'k1'"):
        load_spec(path)


def test_builtin_can_spec_has_the_papers_rig():
    spec = load_spec()
    assert len(spec.key_names) == 12 and len(spec.families) == 5
    assert len(spec.texture_names) == 3
    assert spec.openings.seal and spec.openings.tab


@pytest.mark.parametrize("name, content, needle", [
    ("part.step", b"x", "unsupported format"),
    ("part.stl", b"", "is empty"),
])
def test_bad_mesh_files(tmp_path, name, content, needle):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(UserError, match=needle):
        check_mesh_file(path)
    with pytest.raises(UserError, match="not found"):
        check_mesh_file(tmp_path / "missing.stl")
