"""The command line: a thin Typer layer over :mod:`deformsim.api`; heavy imports stay inside commands."""

from deformsim.cli.app import app

__all__ = ["app"]
