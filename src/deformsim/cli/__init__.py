"""The command line: each command parses its options into a :class:`deformsim.api.Engine`, calls one of its
methods and prints what it returns; heavy imports stay inside the Engine's methods."""

from deformsim.cli.app import app

__all__ = ["app"]
