"""Shared CLI plumbing: the console, and one-line errors instead of tracebacks for bad input."""

from __future__ import annotations

import functools
import sys

import typer
from rich.console import Console

from deformsim.errors import UserError

console = Console()
err_console = Console(stderr=True)


def fail_cleanly(fn):
    """Turn a UserError into ``error: <message>`` (exit 2) and Ctrl-C into a resumable stop (exit 130)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except UserError as exc:
            err_console.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
            raise typer.Exit(2) from None
        except KeyboardInterrupt:
            err_console.print("interrupted: only complete files were kept; rerun the same command to resume")
            sys.exit(130)

    return wrapper
