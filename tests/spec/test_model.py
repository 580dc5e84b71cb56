"""Spec and mesh-file validation: one clear line naming the problem, before any work."""

import pytest

from deformsim.errors import UserError
from deformsim.spec.model import check_mesh_file, load_spec
from tests.util import cli

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


@pytest.mark.parametrize("change, needle", [
    (("amount: 0.3", "amount: .nan"), "amount=nan must be a finite number"),
    (("amount: 0.3", "amount: -.inf"), "amount=-inf must be a finite number"),
    (("amount: 0.3", "amount: 1.0e+300"), "amount=1e+300 must lie in [0, 10]"),
    (("amount: 0.3", "amount: '0.3'"), "amount=0.3 must be a number"),
    (("amount: 0.3", "amount: true"), "amount=True must be a number"),
    (("amount: 0.3", "at: .nan"), "at=nan must be a finite number"),
    (("op: compress, amount: 0.3", "op: twist, angle: 1.0e+9"), "angle=1000000000.0 must lie in [-720, 720]"),
    (("op: compress, amount: 0.3", f"op: crumple, seed: {2**64}"), "seed=18446744073709551616 must lie in [0, "),
    (("op: compress, amount: 0.3", "op: crumple, seed: 1.5"), "seed=1.5 must be an integer"),
    (("op: compress, amount: 0.3", "op: bend, axis: " + "x" * 5000), "axis must be x or y, got xxx"),
    (("units: mm", "units: mm\nsize: .nan"), "size: Input should be a finite number"),
    (("units: mm", "units: mm\nsize: 1.0e+9"), "size: Input should be less than or equal to 1000"),
    (("units: mm", "units: mm\nlattice: {margin: .inf}"), "lattice.margin: Input should be a finite number"),
    (("units: mm", "units: mm\ndisplacement: {vertex_rule: {height_band: [.nan, 1]}}"),
     "displacement.vertex_rule.height_band[0]: Input should be a finite number"),
    (("units: mm", "units: mm\ndisplacement: {vertex_rule: {group: g}, textures: [{name: t, strength: .nan}]}"),
     "textures 't'.strength: Input should be a finite number"),
    (("units: mm", "units: mm\ndisplacement: {vertex_rule: {group: g}, textures: [{name: t, offset: [0, 0, 1.0e+9]}]}"),
     "textures 't'.offset[2]: Input should be less than or equal to 1000"),
    (("units: mm", "units: mm\nmaterial: {roughness: [0.1, .nan]}"), "material.roughness[1]: Input should be a finite"),
])
def test_every_number_of_a_spec_is_finite_and_in_range(tmp_path, change, needle):
    """NaN, infinity and absurd values anywhere in a spec, operation parameters included, are one short line."""
    path = tmp_path / "spec.yaml"
    path.write_text(SPEC.replace(*change))
    with pytest.raises(UserError) as err:
        load_spec(path)
    assert needle in str(err.value) and "\n" not in str(err.value) and len(str(err.value)) < 300, str(err.value)


def test_a_nan_amount_fails_spec_check_in_one_line(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text(SPEC.replace("amount: 0.3", "amount: .nan"))
    proc = cli("spec", "check", str(path))
    assert proc.returncode == 2 and "amount=nan must be a finite number" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


@pytest.mark.parametrize("flag, value", [("--resolution", "100000"), ("--samples", "0")])
def test_spec_preview_sizes_are_in_the_configs_range(tmp_path, flag, value):
    from typer.testing import CliRunner

    from deformsim.cli.app import app

    res = CliRunner().invoke(app, ["spec", "preview", "--out", str(tmp_path / "p.png"), flag, value])
    assert res.exit_code == 2 and f"error: {flag} {value}: invalid render.{flag[2:]}: Input should be" in res.output
    assert not (tmp_path / "p.png").exists()


def test_a_materials_anisotropy_is_optional_and_bounded():
    from deformsim.spec.model import Material

    assert Material().anisotropic is None and Material(anisotropic=0.6).anisotropic == 0.6
    for bad in ({"anisotropic": 1.5}, {"anisotropic": -0.1}, {"anisotropic_rotation": 2}):
        with pytest.raises(ValueError):
            Material(**bad)


def assert_refused(path, material: str, needle: str) -> None:
    """SPEC with the ``material:`` line ``material`` is refused by load_spec in one line that says ``needle``."""
    path.write_text(SPEC.replace("units: mm", f"units: mm\n{material}"))
    with pytest.raises(UserError) as err:
        load_spec(path)
    assert needle in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_material_regions_are_validated_in_one_line(tmp_path):
    region = "{name: ends, where: {min_normal_angle: 60}, roughness: [0.3, 0.5]}"
    path = tmp_path / "spec.yaml"
    path.write_text(SPEC.replace("units: mm", f"units: mm\nmaterial: {{regions: [{region}]}}"))
    (ends,) = load_spec(path).material.regions
    assert ends.where.min_normal_angle == 60 and ends.roughness == (0.3, 0.5) and ends.kind == "metal"
    proc = cli("spec", "check", str(path))
    assert proc.returncode == 0 and "material regions ends" in proc.stdout
    for bad, needle in ((f"[{region}, {region}]", "duplicate region names: ends"),
                        ("[{name: e, where: {}}]", "rule selects nothing"),
                        ("[{name: e, where: {min_normal_angle: 60, max_normal_angle: 30}}]",
                         "min_normal_angle 60.0 must be below max_normal_angle 30.0"),
                        ("[{name: e, where: {min_normal_angle: 95}}]", "min_normal_angle: Input should be less than 90"),
                        ("[{name: e, where: {group: g}, roughness: [0.5, 0.2]}]", "roughness")):
        assert_refused(path, f"material: {{regions: {bad}}}", needle)


def test_printed_marks_are_validated_in_one_line_and_leave_unprinted_specs_as_they_were(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text(SPEC.replace("units: mm", "units: mm\nmaterial: {kind: metal}"))
    assert "print" not in load_spec(path).model_dump(mode="json")["material"], "an unprinted spec's identity stays"
    printed = "{share: 0.5, inks: [[[0, 0.2, 0], [0.1, 0.5, 0.2]]], styles: [ring]}"
    region = f"{{name: ends, where: {{min_normal_angle: 60}}, print: {printed}}}"
    path.write_text(SPEC.replace("units: mm", f"units: mm\nmaterial: {{print: {{}}, regions: [{region}]}}"))
    spec = load_spec(path)
    assert spec.material.print.styles == ["ring", "lines", "dots"] and spec.material.print.share == 1.0
    assert spec.material.regions[0].print.inks == [((0, 0.2, 0), (0.1, 0.5, 0.2))]
    proc = cli("spec", "check", str(path))
    shown = " ".join(proc.stdout.split())
    assert proc.returncode == 0 and "printed material, material regions ends (printed)" in shown, shown
    for bad, needle in (("{share: 1.5}", "share: Input should be less than or equal to 1"),
                        ("{inks: []}", "inks: List should have at least 1 item"),
                        ("{inks: [[[0, 0, 0], [1.2, 0, 0]]]}", "colour range [[0.0, 0.0, 0.0], [1.2, 0.0, 0.0]]"),
                        ("{styles: [stamp]}", "material.print.styles[0]: Input should be 'ring', 'lines' or 'dots'"),
                        ("{ink: [0, 0, 0]}", "material.print.ink")):
        assert_refused(path, f"material: {{print: {bad}}}", needle)
