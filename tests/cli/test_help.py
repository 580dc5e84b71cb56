"""Help and output for a newcomer: literal values kept as typed, no doubled words, piped help at a readable width,
result lines that never wrap into a pipe, and values the shell completes."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys

import pytest
import typer
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.cli.help import HELP_WIDTH
from deformsim.config import load_config
from tests.util import ROOT


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def commands(group=None, path=()):
    group = group or typer.main.get_command(app)
    for name, command in group.commands.items():
        yield (*path, name)
        if hasattr(command, "commands"):
            yield from commands(command, (*path, name))


def flat(text: str) -> str:
    return " ".join(text.replace("│", " ").split())


def test_a_help_text_that_starts_with_a_value_keeps_it_as_typed():
    text = flat(invoke("export-data", "--help").output)
    assert "imagefolder (torchvision, Hugging Face), coco or anomalib." in text
    assert "black, green or a composited variant" in text
    assert "Imagefolder" not in text and "Black, green" not in text
    assert "What trains: head, or tail" in flat(invoke("finetune", "--help").output)  # a plain word still capitalised


def test_every_value_an_option_completes_appears_as_typed_in_its_help():
    """No help text capitalises a value its option takes ("Imagefolder" that --format then refuses)."""
    for path in commands():
        text = flat(invoke(*path, "--help").output)
        for value in ("imagefolder", "black", "green", "head", "tail", "auto", "cpu", "imagenet", "chroma", "local"):
            assert f" {value.capitalize()}, " not in text and f" {value.capitalize()} (" not in text, (path, value)


def test_no_help_repeats_a_word():
    for path in [(), *commands()]:
        text = flat(invoke(*path, "--help").output)
        doubled = re.findall(r"\b([a-z]{3,}) \1\b", text)
        assert not doubled, (path, doubled)
        assert "train trained" not in text and "fewshot fewshot" not in text


def test_every_option_is_described():
    for path in commands():
        command = typer.main.get_command(app)
        for name in path:
            command = command.commands[name]
        for param in command.params:
            if param.param_type_name == "option":
                assert param.help, (path, param.name)


def _piped(*args: str) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "TERMINAL_WIDTH")}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(ROOT)])
    done = subprocess.run([sys.executable, "-m", "deformsim.cli", *args], capture_output=True, text=True, env=env,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_piped_help_is_as_wide_as_a_readable_page():
    lines = _piped("train", "--help").splitlines()
    assert max(len(line) for line in lines) == HELP_WIDTH and 100 <= HELP_WIDTH <= 120
    # the description column has room: the backbone list fits on two lines
    assert "efficientnet_lite0" in "".join(lines)


def test_a_piped_result_line_is_never_wrapped(tmp_path):
    deep = tmp_path / ("folder_" * 20) / ("x" * 60)
    deep.mkdir(parents=True)
    spec = shutil.copy(ROOT / "src" / "deformsim" / "spec" / "builtin" / "can.yaml", deep / "can.yaml")
    lines = _piped("spec", "check", str(spec)).splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"ok {spec}: 'soda-can'") and len(lines[0]) > 200


def complete(words: str, shell: str = "bash") -> list[str]:
    env = {"_DEFORMSIM_COMPLETE": f"complete_{shell}", "COMP_WORDS": words, "COMP_CWORD": str(len(words.split(" ")) - 1),
           "_TYPER_COMPLETE_ARGS": words}
    res = CliRunner().invoke(app, [], prog_name="deformsim", env=env)
    assert res.exit_code == 0, res.output
    return res.output.split()


@pytest.mark.parametrize(("words", "values"), [
    ("deformsim export-data d o --format ", ["imagefolder", "coco", "anomalib"]),
    ("deformsim train d --out m --device ", ["auto", "cpu", "cuda"]),
    ("deformsim generate --device ", ["auto", "cpu", "gpu"]),
    ("deformsim train d --out m --weights ", ["imagenet", "offline", "none"]),
    ("deformsim finetune m --part ", ["head", "tail"]),
    ("deformsim composite d --matte ", ["alpha", "chroma", "inrange"]),
])
def test_value_options_complete_to_their_choices(words, values):
    assert complete(words) == values


def test_backbones_complete_from_the_config():
    from deformsim.learn.backbones import BACKBONES

    assert complete("deformsim train d --out m --backbone ") == list(BACKBONES)
    assert complete("deformsim train d --out m --backbone efficientnet_l") == ["efficientnet_lite0", "efficientnet_lite2"]
    assert set(load_config("quick").train.backbone.split()) <= set(BACKBONES)


def test_variants_complete_from_the_dataset_on_the_command_line(tmp_path):
    for name in ("procedural", "backgrounds"):
        (tmp_path / "variants" / name).mkdir(parents=True)
        (tmp_path / "variants" / name / "manifest.parquet").write_bytes(b"")
    assert complete(f"deformsim train {tmp_path} --out m --variant ") == ["black", "green", "backgrounds", "procedural"]
    assert complete(f"deformsim show {tmp_path} --variant p") == ["procedural"]
    assert complete(f"deformsim report {tmp_path} --variants black,") == [
        "black,green", "black,backgrounds", "black,procedural"]


@pytest.mark.parametrize(("shell", "start"), [("zsh", "#compdef deformsim"), ("bash", "_deformsim_completion()"),
                                              ("fish", "complete --command deformsim")])
def test_show_completion_prints_the_script_of_the_shell_named(shell, start):
    res = CliRunner().invoke(app, ["--show-completion", shell], prog_name="deformsim")
    assert res.exit_code == 0 and res.output.lstrip().startswith(start), res.output[:200]


def test_completion_of_the_shell_names():
    assert complete("deformsim --show-completion z") == ["zsh"]
