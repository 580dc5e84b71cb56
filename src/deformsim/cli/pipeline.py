"""`deformsim run`: the whole pipeline in one command."""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Optional

import typer
from rich.markup import escape

from deformsim.cli.common import (
    REAL_HELP,
    ConfigArgs,
    console,
    err_console,
    fail_cleanly,
    note,
    set_option,
    shortcut,
    shortcut_flags,
    yes_option,
)
from deformsim.cli.summary import report_summary


def register(app: typer.Typer) -> None:
    @app.command("run")
    @fail_cleanly
    def run_cmd(
        config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
        out: Path = typer.Option(Path("runs/demo"), "--out", "-o", help="run folder"),
        real: Optional[Path] = typer.Option(None, "--real", help=f"real photos for sim-to-real: {REAL_HELP}"),
        unlabelled: Optional[Path] = typer.Option(None, "--unlabelled", help="unlabelled photos of real parts (any "
                                                  "folder, no label read): the model adapts to them last, into "
                                                  "OUT/model-adapted (deformsim adapt)"),
        backgrounds: Optional[Path] = shortcut("--backgrounds"),
        object_: Optional[Path] = shortcut("--object"),
        spec: Optional[Path] = shortcut("--spec"),
        n: Optional[int] = shortcut("--n"),
        resolution: Optional[int] = shortcut("--resolution"),
        samples: Optional[int] = shortcut("--samples"),
        epochs: Optional[int] = shortcut("--epochs"),
        seed: Optional[int] = shortcut("--seed"),
        overwrite: bool = typer.Option(
            False, "--overwrite", help="render the dataset anew when it holds more images than --n (else refused)"
        ),
        yes: bool = yes_option(),
        set_: list[str] = set_option(),
        progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
    ) -> None:
        """Generate, composite, train, evaluate and report; stages already up to date are skipped.

        Inputs count by content: an edited mesh, spec, background or real photo reruns what depends on it."""
        flags = shortcut_flags(object_=object_, spec=spec, n=n, resolution=resolution, samples=samples, epochs=epochs,
                               seed=seed, backgrounds=backgrounds)
        result = ConfigArgs(config, flags, sets=set_).engine(progress, note(err_console)).run(out, real,
                                                                                           overwrite=overwrite, yes=yes,
                                                                                           unlabelled=unlabelled)
        if result.seconds:
            console.print("[bold]time per stage:[/]", highlight=False)
        for name, secs in result.seconds.items():
            console.print(f"  {name:<36} {secs:7.1f} s", highlight=False)
        if result.skipped:
            console.print(f"  up to date, skipped: {', '.join(result.skipped)}", highlight=False)
        if result.report is not None:
            report_summary(result.report)
        console.print(f"[bold]Results saved to[/] {escape(str(result.out))}", highlight=False)
        if result.model is not None:
            console.print(f"[bold]predict with its model:[/] deformsim predict {escape(shlex.quote(str(result.model)))} "
                          "PHOTOS...", highlight=False)
        if result.adapted is not None:
            console.print(f"[bold]adapted to the unlabelled photos:[/] {escape(str(result.adapted))}", highlight=False)
