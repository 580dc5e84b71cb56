"""The `deformsim` command line: one module of this package per command group, each with ``register(app)``."""

from __future__ import annotations

import typer

from deformsim.cli import bake, bench, composite, evaluate, export, generate, learn, pipeline, spec

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="deformsim: synthetic deformation datasets and the models trained on them.")

for module in (generate, bake, composite, export, learn, evaluate, spec, pipeline, bench):
    module.register(app)
