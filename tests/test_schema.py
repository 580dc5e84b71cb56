"""What the config and the spec share: range types whose errors name the field, and the one YAML reader, whose
bad bytes and pathological nesting end in one line."""

from __future__ import annotations

import time
from typing import Annotated

import pytest
from pydantic import ValidationError
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.errors import UserError
from deformsim.schema import (
    MAX_YAML_BYTES,
    MAX_YAML_NODES,
    Above,
    FractionRange,
    NonEmpty,
    Range,
    StrictModel,
    Within,
    check_range,
    load_yaml,
    read_mapping,
    shown,
)
from tests.util import CARTON_SPEC


class Ranges(StrictModel):
    share: FractionRange | None = None
    size: Annotated[Range, Within(above=0)] = (1.0, 2.0)
    weight: Annotated[Range, Within(0)] = (0.0, 1.0)
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


def laughs(key: str, levels: int) -> str:
    """YAML whose ``key`` holds a "billion laughs": ``levels`` lists of 10 aliases each, 10**levels strings."""
    lines = ['    l0: &l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"    l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, levels)]
    parent, leaf = key.split(".") if "." in key else (None, key)
    head = f"{parent}:\n  {leaf}:\n" if parent else f"{leaf}:\n"
    return head + "\n".join(line if parent else line[2:] for line in lines) + "\n"


@pytest.mark.parametrize("what", ["config", "spec"])
def test_aliases_that_expand_past_the_limit_are_one_short_line(tmp_path, what):
    """A billion-laughs value under one key is refused while it is read, in one short line."""
    path = tmp_path / "bomb.yaml"
    path.write_text(laughs("render.look", 7) if what == "config" else laughs("name", 7) + "families: []\n")
    args = {"config": ["generate", "--out", str(tmp_path / "out"), "--config", str(path)],
            "spec": ["spec", "check", str(path)]}[what]
    t0 = time.perf_counter()
    res = CliRunner().invoke(app, args)
    text = " ".join(res.output.split())
    assert time.perf_counter() - t0 < 5 and res.exit_code == 2 and len(text) < 300, text[:300]
    assert f"{what} {path} is not valid YAML: it expands to more than {MAX_YAML_NODES} values" in text
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("text, needle", [
    ("a: &x [1, *x]\n", "an alias refers to its own anchor"),
    ("a: " + "9" * 5000 + "\n", "Exceeds the limit (4300 digits)"),
])
def test_recursive_aliases_and_endless_integers_are_one_line(tmp_path, text, needle):
    path = tmp_path / "c.yaml"
    path.write_text(text)
    with pytest.raises(UserError) as exc:
        read_mapping(path, "config")
    assert needle in str(exc.value) and len(str(exc.value)) < 300


def test_a_file_too_large_to_be_a_config_is_not_read(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_bytes(b"# " + b"x" * MAX_YAML_BYTES + b"\n")
    with pytest.raises(UserError, match="is larger than 1 MiB: too large to be a config"):
        read_mapping(path, "config")


def test_aliases_within_the_limit_still_read():
    assert load_yaml("a: &x [1, 2]\nb: *x\nc: {<<: {k: 1}}\n") == {"a": [1, 2], "b": [1, 2], "c": {"k": 1}}


@pytest.mark.parametrize("data", [{"size": [float("nan"), 1]}, {"lens": float("inf")}, {"lens": [35, float("nan")]},
                                  {"views": [[0, float("-inf")]]}])
def test_strict_models_refuse_nan_and_infinity(data):
    with pytest.raises(ValidationError, match="finite"):
        Ranges.model_validate(data)
    with pytest.raises(ValueError, match="finite"):
        check_range((float("nan"), 1.0))


def test_shown_values_are_short():
    assert shown("x" * 10**6).endswith("...") and len(shown("x" * 10**6)) == 80
    assert len(shown([[["lol"] * 1000] * 1000] * 1000)) <= 80
    assert shown(10**5000) == "a number too long to show" and shown([1, 2]) == "[1, 2]"


def test_a_key_given_twice_is_refused_by_name(tmp_path):
    """YAML keeps the last of two equal keys silently: `generate: {n: 4}` then `generate: {n: 8}` meant n 8."""
    from deformsim.errors import UserError
    from deformsim.schema import read_mapping

    for text, key, line in (("generate: {n: 4}\ngenerate: {n: 8}\n", "generate", 2), ("a:\n  n: 1\n  m: 2\n  n: 3\n",
                                                                                     "n", 4)):
        path = tmp_path / "c.yaml"
        path.write_text(text)
        with pytest.raises(UserError, match=rf"not valid YAML: the key '{key}' appears twice .*line {line}"):
            read_mapping(path, "config")
    path.write_text("base: &b {x: 1}\nmore:\n  <<: *b\n  y: 2\n")
    assert read_mapping(path, "config")["more"] == {"x": 1, "y": 2}  # a merge key is no repeat
