"""The Python API: the README's example runs as written, and Engine validates its config."""

from __future__ import annotations

import re

import pytest

from deformsim import Engine
from deformsim.config import load_config
from deformsim.errors import UserError
from tests.util import ROOT


def readme_example() -> str:
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README.md has no Python example"
    return blocks[0]


@pytest.mark.blender
@pytest.mark.torch
def test_readme_python_example_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(readme_example(), "README.md", "exec"), {})
    assert (tmp_path / "out" / "model" / "model.pt").is_file()
    assert re.search(r"accuracy on the black variant: [01]\.\d\d", capsys.readouterr().out)


def test_engine_takes_a_config_object_with_overrides():
    engine = Engine(load_config("quick"), {"render.resolution": 96, "train.epochs": None})
    assert engine.config.render.resolution == 96 and engine.config.train.epochs == 15


def test_engine_refuses_a_bad_override_with_one_line():
    with pytest.raises(UserError, match="render.resolution"):
        Engine("quick", {"render.resolution": -1})
