"""`deformsim generate`: render a labelled intact/deformed dataset."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import console, fail_cleanly


def generate(
    out: Path = typer.Option(..., "--out", "-o", help="output folder (rerun to resume)"),
    config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
    n: Optional[int] = typer.Option(None, "--n", help="number of images"),
    resolution: Optional[int] = typer.Option(None, help="image size in pixels"),
    samples: Optional[int] = typer.Option(None, help="Cycles samples per pixel"),
    seed: Optional[int] = typer.Option(None, help="seed fixing every random choice"),
    workers: Optional[int] = typer.Option(None, help="render processes (0 = automatic)"),
    device: Optional[str] = typer.Option(None, help="auto, cpu or gpu"),
    object_: Optional[Path] = typer.Option(None, "--object", help="CAD mesh instead of the built-in can"),
    spec: Optional[Path] = typer.Option(None, "--spec", help="deformation spec YAML"),
    backend: Optional[str] = typer.Option(None, help="local or ray"),
    address: Optional[str] = typer.Option(None, help="Ray cluster address (HOST:PORT or auto)"),
    gather: Optional[bool] = typer.Option(None, "--gather/--no-gather", help="Ray: return images to the driver"),
    progress: bool = typer.Option(True, "--progress/--no-progress"),
) -> None:
    """Render a balanced, labelled intact/deformed dataset with Blender."""
    from deformsim.config import load_config
    from deformsim.generate.stage import generate as run

    cfg = load_config(config, {
        "generate.n": n, "render.resolution": resolution, "render.samples": samples, "generate.seed": seed,
        "generate.workers": workers, "render.device": device, "object.mesh": object_, "object.spec": spec,
        "generate.backend": backend, "generate.address": address, "generate.gather": gather,
    })
    result = run(cfg, out, progress=progress)
    console.print(
        f"[bold]{result.images}[/] images in {out} ({result.rendered} samples rendered now, "
        f"{result.seconds:.0f} s{', ' + result.device if result.device else ''}); "
        f"manifest: {out / 'manifest.parquet'}, preview: {out / 'preview.png'}"
    )
    if result.failed:
        console.print(f"[red]{len(result.failed)} sample(s) failed[/]: see {out / 'failures.json'}")
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    app.command()(fail_cleanly(generate))
