"""Spec and mesh-file validation: one clear line naming the problem, before any work."""

import pytest

from deformsim.errors import UserError
from deformsim.spec.model import check_mesh_file, load_spec

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
