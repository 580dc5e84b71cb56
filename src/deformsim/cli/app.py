"""The `deformsim` command line: one module of this package per command group, each with ``register(app)``."""

from __future__ import annotations

import typer

from deformsim.cli import (
    adapt,
    bake,
    bench,
    composite,
    configuration,
    evaluate,
    export,
    finetune,
    generate,
    learn,
    pipeline,
    show,
    spec,
)
from deformsim.cli.common import fail_cleanly
from deformsim.cli.help import use_words
from deformsim.errors import UserError
from deformsim.version import __version__

app = typer.Typer(add_completion=True, no_args_is_help=True,
                  help="deformsim: synthetic deformation datasets and the models trained on them.")


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"deformsim {__version__}")
        raise typer.Exit()


@app.callback()
@fail_cleanly
def main(
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Print warnings, errors and results only."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Also print debug lines, such as every epoch's."),
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                 help="Print the version and exit."),
) -> None:
    from deformsim.log import set_verbosity

    if quiet and verbose:
        raise UserError("--quiet and --verbose exclude each other: give one")
    set_verbosity("quiet" if quiet else "verbose" if verbose else "normal")


for module in (generate, bake, composite, export, learn, finetune, adapt, evaluate, spec, show, pipeline, bench, configuration):
    module.register(app)
use_words(app)
