"""The `deformsim` command line: one module of this package per command group, each with ``register(app)``."""

from __future__ import annotations

from typing import Optional

import typer
from typer.completion import completion_init

from deformsim.cli import (
    adapt,
    bake,
    bench,
    checks,
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
from deformsim.cli.choices import SHELLS, completes
from deformsim.cli.common import fail_cleanly
from deformsim.cli.help import QUIET_HELP, VERBOSE_HELP, use_words, verbosity

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="deformsim: synthetic deformation datasets and the models trained on them.")


def _print_version(value: bool) -> None:
    if value:
        from deformsim.cli.checks import version_line

        typer.echo(version_line())
        raise typer.Exit()


def _completion(ctx: typer.Context, param, shell: str | None) -> None:
    """Print (``--show-completion``) or install (``--install-completion``) the completion script of ``shell``."""
    if shell is None or ctx.resilient_parsing:
        return
    from typer._completion_shared import get_completion_script, install

    if shell not in SHELLS:
        raise typer.BadParameter(f"{shell!r}: give one of {', '.join(SHELLS)}")
    prog = ctx.find_root().info_name or "deformsim"
    var = "_{}_COMPLETE".format(prog.replace("-", "_").replace(".", "_").upper())
    if param.name == "show_completion":
        typer.echo(get_completion_script(prog_name=prog, complete_var=var, shell=shell))
    else:
        _, path = install(shell=shell, prog_name=prog, complete_var=var)
        typer.echo(f"{shell} completion installed in {path}; it takes effect in a new shell")
    raise typer.Exit()


@app.callback()
@fail_cleanly
def main(
    quiet: bool = typer.Option(False, "--quiet", "-q", help=QUIET_HELP),
    verbose: bool = typer.Option(False, "--verbose", "-v", help=VERBOSE_HELP),
    version: bool = typer.Option(False, "--version", "-V", callback=_print_version, is_eager=True,
                                 help="Print the version of deformsim and of what it runs on (deformsim checks: "
                                 "the devices and weights too) and exit."),
    install_completion: Optional[str] = typer.Option(
        None, "--install-completion", metavar="SHELL", callback=_completion, is_eager=True, expose_value=False,
        autocompletion=completes(*SHELLS), help=f"Install completion for SHELL ({', '.join(SHELLS)})."),
    show_completion: Optional[str] = typer.Option(
        None, "--show-completion", metavar="SHELL", callback=_completion, is_eager=True, expose_value=False,
        autocompletion=completes(*SHELLS), help=f"Print the completion script of SHELL ({', '.join(SHELLS)}), to "
        "copy or customise."),
) -> None:
    verbosity(quiet, verbose)


for module in (generate, bake, composite, export, learn, finetune, adapt, evaluate, spec, show, pipeline, bench,
               configuration, checks):
    module.register(app)
use_words(app)
completion_init()  # Typer's completion scripts and their answers, as add_completion would
