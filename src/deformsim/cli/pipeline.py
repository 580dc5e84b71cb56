"""`deformsim run`: the whole pipeline in one command."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import REAL_HELP, ConfigArgs, console, fail_cleanly, note


def register(app: typer.Typer) -> None:
    @app.command("run")
    @fail_cleanly
    def run_cmd(
        config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
        out: Path = typer.Option(Path("runs/demo"), "--out", "-o", help="run folder"),
        real: Optional[Path] = typer.Option(None, "--real", help=f"real photos for sim-to-real: {REAL_HELP}"),
        backgrounds: Optional[Path] = typer.Option(None, "--backgrounds", help="background photos (default: procedural)"),
        object_: Optional[Path] = typer.Option(None, "--object", help="CAD mesh instead of the built-in can"),
        spec: Optional[Path] = typer.Option(None, "--spec", help="deformation spec YAML for --object"),
        n: Optional[int] = typer.Option(None, "--n", help="number of images"),
        resolution: Optional[int] = typer.Option(None, help="image size in pixels"),
        samples: Optional[int] = typer.Option(None, help="Cycles samples per pixel"),
        epochs: Optional[int] = typer.Option(None, help="training epochs"),
        seed: Optional[int] = typer.Option(None, help="seed fixing every random choice"),
        overwrite: bool = typer.Option(
            False, "--overwrite", help="render the dataset anew when it holds more images than --n (else refused)"
        ),
        yes: bool = typer.Option(
            False, "--yes", help="start a plan of more than 100000 images (without it: the estimated time and disk, and a stop)"
        ),
        progress: bool = typer.Option(True, "--progress/--no-progress"),
    ) -> None:
        """Generate, composite, train, evaluate and report; stages already up to date are skipped.

        Inputs count by content: an edited mesh, spec, background or real photo reruns what depends on it."""
        result = ConfigArgs(config, {
            "--object": ("object.mesh", object_), "--spec": ("object.spec", spec), "--n": ("generate.n", n),
            "--resolution": ("render.resolution", resolution), "--samples": ("render.samples", samples),
            "--epochs": ("train.epochs", epochs), "--seed": ("generate.seed", seed),
            "--backgrounds": ("composite.backgrounds", backgrounds),
        }).engine(progress, note(console)).run(out, real, overwrite=overwrite, yes=yes)
        for name, secs in result.seconds.items():
            console.print(f"  {name:<24} {secs:7.1f} s")
        if result.skipped:
            console.print(f"  up to date, skipped: {', '.join(result.skipped)}")
        console.print(f"[bold green]report:[/] {result.report}")
