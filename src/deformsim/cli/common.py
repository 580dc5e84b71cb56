"""Shared CLI plumbing: the console, one-line errors instead of tracebacks, and SIGTERM handled like Ctrl-C."""

from __future__ import annotations

import functools
import signal
import sys
from pathlib import Path

import typer
from rich.console import Console

from deformsim.dataset.images import REAL_RULE as REAL_HELP
from deformsim.errors import UserError

__all__ = ["REAL_HELP", "console", "err_console", "fail_cleanly", "load_cli_config"]

console = Console()
err_console = Console(stderr=True)

RESUME = "only complete files were kept; rerun the same command to resume"


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that every Ctrl-C cleanup (workers stopped, partial files removed) runs."""


def _terminate(signum, frame) -> None:
    raise Terminated()


def error(message: str) -> None:
    err_console.print(f"[bold red]error:[/] {message}", highlight=False, soft_wrap=True, markup=True)


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
    from rich.markup import escape

    return escape(text)


def load_cli_config(source: str | Path | None, flags: dict[str, tuple[str, object]]):
    """The config from ``source`` with command-line values applied.

    ``flags`` maps each flag (``"--n"``) to its dotted config key and value (None: not given); a bad value is
    reported as the flag the user typed, not as the config file.
    """
    from deformsim.config import load_config

    return load_config(source, {key: value for key, value in flags.values()},
                       flags={key: flag for flag, (key, _) in flags.items()})
