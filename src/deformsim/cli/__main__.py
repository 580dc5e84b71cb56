"""``python -m deformsim.cli``."""

from deformsim.cli.app import app

app()
