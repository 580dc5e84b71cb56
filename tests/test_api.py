"""The Python API: the README's example runs as written; Engine validates its config and checks inputs first."""

from __future__ import annotations

import re
import shutil

import pytest

from deformsim import Engine
from deformsim.config import load_config
from deformsim.errors import UserError
from tests.util import ROOT, TINY


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
    engine = Engine(load_config("quick", {"camera.fill": [0.3, 0.6]}), {"render.resolution": 96, "camera.fill": None})
    assert engine.config.render.resolution == 96 and engine.config.camera.fill is None


def test_engine_refuses_a_bad_override_with_one_line():
    with pytest.raises(UserError, match="render.resolution"):
        Engine("quick", {"render.resolution": -1})


def test_engine_names_the_flag_of_a_bad_override():
    with pytest.raises(UserError, match=r"^--resolution -1: invalid render.resolution"):
        Engine("quick", {"render.resolution": -1}, flags={"render.resolution": "--resolution"})


def test_spec_check_and_bake_refusal_need_no_blender(tmp_path, carton):
    spec = ROOT / "examples" / "carton" / "spec.yaml"
    checked = Engine().spec_check(spec)
    assert checked.spec.name and checked.size is None and checked.hint is None
    bare = tmp_path / "bare.yaml"
    bare.write_text(spec.read_text().split("\nsimulation:")[0] + "\n")
    with pytest.raises(UserError, match="declares no simulation scenarios"):
        Engine("quick", {"object.spec": bare, "object.mesh": carton}).bake()


def test_evaluate_checks_its_output_before_any_work_and_notes_what_it_found(tmp_path):
    notes = []
    with pytest.raises(UserError, match="is a folder"):
        Engine(notify=notes.append).evaluate(tmp_path / "no-model", real=tmp_path, out=tmp_path)
    assert notes == []
    with pytest.raises(UserError, match="no intact/"):
        Engine(notify=notes.append).evaluate(tmp_path / "no-model", real=tmp_path)


def test_generate_says_which_composited_variants_the_grown_dataset_left_behind(tiny_dataset, tmp_path, caplog):
    """More samples into a composited dataset: the variant holds the old images only. ``deformsim generate`` says so;
    the stage alone does not, as ``deformsim run`` and the benchmark composite the variant again right after."""
    from deformsim.generate.stage import generate

    def variant_warnings() -> list[str]:
        return [r.getMessage() for r in caplog.records if r.levelname == "WARNING" and "variant" in r.getMessage()]

    data = tmp_path / "data"
    shutil.copytree(tiny_dataset, data)
    Engine("quick", TINY).composite(data, name="old")
    generate(load_config("quick", {**TINY, "generate.n": 12}), data, progress=False)
    assert variant_warnings() == []
    Engine("quick", {**TINY, "generate.n": 12}).generate(data)  # nothing left to render
    assert variant_warnings() == ["variant old holds other images than the dataset's 12 now: rerun deformsim "
                                  "composite to update it"]
    caplog.clear()
    Engine("quick", TINY).composite(data, name="old")
    Engine("quick", {**TINY, "generate.n": 12}).generate(data)
    assert variant_warnings() == []
