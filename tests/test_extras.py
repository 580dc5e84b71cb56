"""The pip extras: the core installs none of the heavy packages, and each extra installs what deformsim names it for."""

from __future__ import annotations

import re
import tomllib

import pytest

from deformsim.errors import UserError
from deformsim.extras import EXTRAS, MissingExtra, as_missing_extra, require
from tests.util import ROOT

PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _names(requirements: list[str]) -> set[str]:
    return {re.match(r"[A-Za-z0-9_.-]+", r).group(0).lower() for r in requirements}


def test_the_core_installs_no_extra_and_each_extra_installs_its_modules():
    core, extras = _names(PROJECT["dependencies"]), PROJECT["optional-dependencies"]
    heavy = {m.lower() for modules in EXTRAS.values() for m in modules}
    assert not core & heavy and "onnxruntime" in core  # predicting with an exported model needs no extra
    for extra, modules in EXTRAS.items():
        assert {m.lower() for m in modules} <= _names(extras[extra]), extra
    assert extras["all"] == [f"deformsim[{','.join(EXTRAS)}]"]


def test_a_missing_module_is_one_line_naming_its_extra(monkeypatch):
    err = as_missing_extra(ModuleNotFoundError("No module named 'torch'", name="torch"))
    assert isinstance(err, UserError) and str(err) == ("this command needs torch, which is not installed: "
                                                      "pip install 'deformsim[train]'")
    assert as_missing_extra(ModuleNotFoundError("No module named 'nope'", name="nope")) is None
    monkeypatch.setattr("importlib.util.find_spec", lambda name: None if name == "OpenEXR" else object())
    with pytest.raises(MissingExtra) as info:
        require("train", "render", what="rendering")
    assert str(info.value) == "rendering needs OpenEXR, which is not installed: pip install 'deformsim[render]'"
