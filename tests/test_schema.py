"""The one YAML reader of config and spec: bad bytes and pathological nesting end in one line (issue #10, finding 5)."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from deformsim.cli.app import app
from tests.util import CARTON_SPEC

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
