"""What the config and the spec share: range types whose errors name the field, and the one YAML reader, whose
bad bytes and pathological nesting end in one line."""

from __future__ import annotations

from typing import Annotated

import pytest
from pydantic import ValidationError
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.schema import Above, FractionRange, NonEmpty, NonNegativeRange, PositiveRange, Range, StrictModel, Within
from tests.util import CARTON_SPEC


class Ranges(StrictModel):
    share: FractionRange | None = None
    size: PositiveRange = (1.0, 2.0)
    weight: NonNegativeRange = (0.0, 1.0)
    angle: Annotated[Range, Within(0, 180)] = (0.0, 90.0)
    lens: Annotated[float | Range, Above(1)] = 50.0
    views: Annotated[list[Annotated[Range, Within(-360, 720)]], NonEmpty("at least one view is needed")] = [(0, 1)]


@pytest.mark.parametrize("data, message", [
    ({"share": [0, 0.5]}, "share range [0.0, 0.5] must be above 0"),
    ({"share": [0.5, 1.2]}, "share range [0.5, 1.2] goes above 1"),
    ({"size": [2, 1]}, "size range [2.0, 1.0] is empty (min > max)"),
    ({"weight": [-1, 1]}, "weight range [-1.0, 1.0] is negative"),
    ({"angle": [10, 190]}, "angle range [10.0, 190.0] goes above 180"),
    ({"lens": 0.5}, "lens 0.5 must be above 1"),
    ({"lens": [1, 35]}, "lens range [1.0, 35.0] must be above 1"),
    ({"views": []}, "at least one view is needed"),
    ({"views": [[0, 1], [-400, 0]]}, "views range [-400.0, 0.0] goes below -360"),
])
def test_range_types_name_the_field(data, message):
    with pytest.raises(ValidationError) as exc:
        Ranges.model_validate(data)
    assert exc.value.errors()[0]["msg"] == f"Value error, {message}"


def test_range_types_accept_their_bounds_and_keep_the_values():
    r = Ranges.model_validate({"share": [0.2, 1], "weight": [0, 0], "angle": [0, 180], "lens": [35, 85]})
    assert (r.share, r.weight, r.angle, r.lens) == ((0.2, 1.0), (0.0, 0.0), (0.0, 180.0), (35.0, 85.0))
    assert r.model_dump(mode="json")["share"] == [0.2, 1.0]

NOT_UTF8 = "name: caf\u00e9\n".encode("latin-1")
DEEP = ("a: " + "[" * 20000 + "]" * 20000 + "\n").encode()


@pytest.mark.parametrize("content, needle", [(NOT_UTF8, "is not UTF-8 text (byte 9): save it as UTF-8"),
                                             (DEEP, "is nested too deeply")], ids=["latin-1", "deep"])
@pytest.mark.parametrize("what", ["config", "spec"])
def test_bad_yaml_is_one_line(tmp_path, what, content, needle):
    path = tmp_path / "bad.yaml"
    path.write_bytes(content)
    args = {"config": ["generate", "--out", str(tmp_path / "out"), "--config", str(path)],
            "spec": ["spec", "check", str(path)]}[what]
    res = CliRunner().invoke(app, args)
    text = res.output.strip()
    assert res.exit_code == 2 and len(text.splitlines()) == 1 and "Traceback" not in text, text
    assert f"{what} {path}" in " ".join(text.split()) and needle in text
    assert not (tmp_path / "out").exists()


def test_a_good_spec_still_checks():
    res = CliRunner().invoke(app, ["spec", "check", str(CARTON_SPEC)])
    assert res.exit_code == 0 and "ok" in res.output
