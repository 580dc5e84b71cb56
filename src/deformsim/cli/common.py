"""Shared CLI plumbing: a command's options as an Engine, the console, one-line errors instead of tracebacks,
and SIGTERM handled like Ctrl-C."""

from __future__ import annotations

import difflib
import functools
import signal
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import typer
from rich.console import Console

from deformsim.dataset.images import REAL_RULE as REAL_HELP
from deformsim.errors import UserError

__all__ = ["REAL_HELP", "SHORTCUTS", "ConfigArgs", "console", "err_console", "fail_cleanly", "from_config", "note",
           "parse_sets", "plain_engine", "set_option", "shortcut", "shortcut_flags", "yes_option"]



class _Console(Console):
    """A console whose lines wrap only on a terminal: into a file or pipe each printed line stays one line."""

    @property
    def soft_wrap(self) -> bool:
        return self._soft_wrap or not self.is_terminal

    @soft_wrap.setter
    def soft_wrap(self, value: bool) -> None:
        self._soft_wrap = value


console = _Console()
err_console = _Console(stderr=True)

RESUME = "only complete files were kept; rerun the same command to resume"


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that every Ctrl-C cleanup (workers stopped, partial files removed) runs."""


def _terminate(signum, frame) -> None:
    raise Terminated()


LONGEST_WORD = 100  # characters of one path or value an error line shows (its start and end)
LONGEST_LINE = 290


def error(message: str) -> None:
    """Print ``error: MESSAGE`` (rich markup, escaped by the caller) on one line of at most :data:`LONGEST_LINE`
    characters: a huge path or value in it is cut in the middle, the line at its end."""
    from deformsim.schema import clip

    words = [w if len(w) <= LONGEST_WORD else f"{w[:45]}...{w[-52:]}" for w in message.split()]
    line = clip(" ".join(words), LONGEST_LINE)
    err_console.print(f"[bold red]error:[/] {line}", highlight=False, soft_wrap=True, markup=True)


def fail_cleanly(fn):
    """Turn a UserError into ``error: <message>`` (exit 2, 1 for a full disk), an OSError into one line, Ctrl-C
    into a resumable stop (exit 130) and SIGTERM into the same stop (exit 143)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            previous = signal.signal(signal.SIGTERM, _terminate)
        except ValueError:  # not the main thread: leave signals alone
            previous = None
        try:
            return fn(*args, **kwargs)
        except UserError as exc:
            error(_escape(str(exc)))
            raise typer.Exit(exc.exit_code) from None
        except Terminated:
            err_console.print(f"terminated: {RESUME}")
            sys.exit(143)
        except KeyboardInterrupt:
            err_console.print(f"interrupted: {RESUME}")
            sys.exit(130)
        except ModuleNotFoundError as exc:  # a module of an extra that is not installed: the extra in one line
            from deformsim.extras import as_missing_extra

            missing = as_missing_extra(exc)
            if missing is None:
                raise
            error(_escape(str(missing)))
            raise typer.Exit(missing.exit_code) from None
        except OSError as exc:
            from deformsim.outputs import os_error_line

            message, code = os_error_line(exc)
            error(_escape(message))
            raise typer.Exit(code) from None
        finally:
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)

    return wrapper


def _escape(text: str) -> str:
    """``text`` for rich's markup, printable whatever the bytes of the names in it (:func:`deformsim.atomic.printable`)."""
    from rich.markup import escape

    from deformsim.atomic import printable

    return escape(printable(text))


@dataclass(frozen=True)
class ConfigArgs:
    """What a command's options say about its config: the YAML file or preset, and the config keys they set.

    ``flags`` maps each flag (``"--n"``) to its dotted config key and value (None: not given); a bad value is
    reported as the flag the user typed, not as the config file. ``overrides`` sets dotted keys that no flag
    names (a bad value is reported as ``override KEY``), and ``sets`` are the ``--set KEY=VALUE`` options, which
    win over ``overrides``; a given flag wins over both.
    """

    source: str | Path | None = None
    flags: dict[str, tuple[str, object]] = field(default_factory=dict)
    overrides: dict[str, object] = field(default_factory=dict)
    sets: Sequence[str] = ()

    def engine(self, progress: bool = True, notify: Callable[[str], None] | None = None):
        """The :class:`deformsim.api.Engine` of this config."""
        from deformsim.api import Engine
        from deformsim.config import load_config

        given = {flag: (key, value) for flag, (key, value) in self.flags.items() if value is not None}
        sets = parse_sets(self.sets)
        flags = {**{key: f"--set {key}" for key in sets}, **{key: flag for flag, (key, _) in given.items()}}
        final = {**self.overrides, **sets, **dict(given.values())}
        # a value that another one overrides is checked too (in place of the winner): no bad value passes unseen
        winners = {key for key, _ in given.values()}
        shadowed = [*((k, v, f"override {k}") for k, v in self.overrides.items() if k in winners or k in sets),
                    *((k, v, f"--set {k}") for k, v in sets.items() if k in winners)]
        for key, value, flag in shadowed:
            load_config(self.source, {**final, key: value}, {**flags, key: flag})
        return Engine(self.source, final, progress=progress, flags=flags, notify=notify)


@functools.cache
def _quick() -> dict:
    from deformsim.config import load_config

    return load_config("quick").model_dump(mode="json")


def from_config(text: str, key: str) -> str:
    """The help of an option that sets config ``key``: ``text`` and where its default comes from."""
    value = _quick()
    for part in key.split("."):
        value = value[part]
    shown = ", ".join(map(str, value)) if isinstance(value, list) else "null" if value is None else str(value)
    return f"{text} (default: {key} of the config, {shown} in quick)"


class Shortcut(NamedTuple):
    key: str  # the config key the flag sets
    help: str
    shows_default: bool = True  # the help names the key's default (:func:`from_config`)
    decls: tuple[str, ...] = ()  # the option's names, when not just the flag


# The flags that set one config key each, shared by the commands that take them (``generate``, ``run``).
SHORTCUTS = {
    "--n": Shortcut("generate.n", "Number of images"),
    "--resolution": Shortcut("render.resolution", "Image size in pixels"),
    "--samples": Shortcut("render.samples", "Cycles samples per pixel"),
    "--seed": Shortcut("generate.seed", "Seed fixing every random choice"),
    "--workers": Shortcut("generate.workers", "Render processes, 0 = automatic"),
    "--device": Shortcut("render.device", "Render device: auto, cpu or gpu"),
    "--backend": Shortcut("generate.backend", "Where workers run: local or ray"),
    "--address": Shortcut("generate.address", "Ray cluster address (HOST:PORT or auto)", False),
    "--gather": Shortcut("generate.gather", "Ray: return images to the driver", decls=("--gather/--no-gather",)),
    "--epochs": Shortcut("train.epochs", "Training epochs"),
    "--object": Shortcut("object.mesh", "CAD mesh instead of the built-in can", False),
    "--spec": Shortcut("object.spec", "deformation spec YAML (for --object)", False),
    "--backgrounds": Shortcut("composite.backgrounds", "background photos (default: procedural)", False),
}


def shortcut(flag: str):
    """The typer option of the :data:`SHORTCUTS` flag ``flag`` (unset: None, the config's value)."""
    from deformsim.cli.choices import completes, config_values

    s = SHORTCUTS[flag]
    values = config_values(s.key)
    return typer.Option(None, *(s.decls or (flag,)), help=from_config(s.help, s.key) if s.shows_default else s.help,
                        autocompletion=completes(*values) if values else None)


def shortcut_flags(**values) -> dict[str, tuple[str, object]]:
    """The ``flags`` of :class:`ConfigArgs` for :data:`SHORTCUTS` options given by parameter name (``object_=...``
    is ``--object``)."""
    flags = {f"--{name.rstrip('_')}": value for name, value in values.items()}
    return {flag: (SHORTCUTS[flag].key, value) for flag, value in flags.items()}


def plain_engine(progress: bool = True, overrides: dict | None = None, notify: Callable[[str], None] | None = None):
    """An Engine for a command that reads no config: the default settings, no file read."""
    from deformsim.api import Engine
    from deformsim.config import Config

    return Engine(Config(), overrides, progress=progress, notify=notify)


def set_option():
    """The ``--set KEY=VALUE`` option of a command that takes a config (read by :func:`parse_sets`)."""
    return typer.Option([], "--set", metavar="KEY=VALUE",
                        help="Set any config key, e.g. train.epochs=5; repeatable. Every key: deformsim config show.")


def yes_option():
    """The ``--yes`` option of a command that renders: it starts a plan larger than the confirmation limit."""
    return typer.Option(
        False, "--yes", help="start a plan of more than 100000 images (without it: the estimated time and disk, and a stop)"
    )


def parse_sets(items: Sequence[str]) -> dict:
    """``["train.epochs=5", ...]`` (``--set`` options) as dotted overrides; values are read as YAML scalars or lists.
    A key the config does not have is refused with the closest key that it has."""
    import yaml

    from deformsim.schema import load_yaml, shown

    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UserError(f"--set {shown(repr(item))}: expected KEY=VALUE, e.g. train.epochs=5")
        _check_key(key.strip())
        try:
            out[key.strip()] = load_yaml(value)
        except yaml.YAMLError:
            raise UserError(f"--set {shown(repr(item))}: the value is not valid YAML") from None
    return out


def _check_key(key: str) -> None:
    """Refuse a dotted key that is no config field, naming the closest one."""
    from deformsim.config_reference import dotted_keys
    from deformsim.schema import shown

    keys = dotted_keys()
    if key in keys:
        return
    close = difflib.get_close_matches(key, keys, n=1, cutoff=0.6)
    hint = f"did you mean {close[0]}?" if close else "deformsim config show lists every key"
    raise UserError(f"--set {shown(key)}: no such config key ({hint})")


def note(target: Console) -> Callable[[str], None]:
    """Print an Engine's notes on ``target`` (the console or the error console)."""
    return lambda line: target.print(line, highlight=False, soft_wrap=True)
