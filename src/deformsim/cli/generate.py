"""`deformsim generate`: render a labelled intact/deformed dataset."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.choices import config_choices
from deformsim.cli.common import ConfigArgs, console, fail_cleanly, from_config, set_option


def generate(
    out: Path = typer.Option(..., "--out", "-o", help="output folder (rerun to resume)"),
    config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
    n: Optional[int] = typer.Option(None, "--n", help=from_config("Number of images", "generate.n")),
    resolution: Optional[int] = typer.Option(None, help=from_config("Image size in pixels", "render.resolution")),
    samples: Optional[int] = typer.Option(None, help=from_config("Cycles samples per pixel", "render.samples")),
    seed: Optional[int] = typer.Option(None, help=from_config("Seed fixing every random choice", "generate.seed")),
    workers: Optional[int] = typer.Option(None, help=from_config("Render processes, 0 = automatic", "generate.workers")),
    device: Optional[str] = typer.Option(None, autocompletion=config_choices("render.device"),
                                         help=from_config("Render device: auto, cpu or gpu", "render.device")),
    object_: Optional[Path] = typer.Option(None, "--object", help="CAD mesh instead of the built-in can"),
    spec: Optional[Path] = typer.Option(None, "--spec", help="deformation spec YAML"),
    backend: Optional[str] = typer.Option(None, autocompletion=config_choices("generate.backend"),
                                          help=from_config("Where workers run: local or ray", "generate.backend")),
    address: Optional[str] = typer.Option(None, help="Ray cluster address (HOST:PORT or auto)"),
    gather: Optional[bool] = typer.Option(None, "--gather/--no-gather",
                                          help=from_config("Ray: return images to the driver", "generate.gather")),
    overwrite: bool = typer.Option(
        False, "--overwrite", help="replace a dataset in --out made with other settings, inputs or more images"
    ),
    yes: bool = typer.Option(
        False, "--yes", help="start a plan of more than 100000 images (without it: the estimated time and disk, and a stop)"
    ),
    set_: list[str] = set_option(),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while rendering."),
) -> None:
    """Render a balanced, labelled intact/deformed dataset with Blender.

    Rerunning on the same folder resumes, or extends it with a larger --n. A folder rendered with other
    settings, another mesh or spec content, or more images than --n is refused unless --overwrite is given,
    which removes it as a whole and renders anew. More than 100000 images print their estimated time and
    disk and stop unless --yes is given."""
    result = ConfigArgs(config, {
        "--n": ("generate.n", n), "--resolution": ("render.resolution", resolution),
        "--samples": ("render.samples", samples), "--seed": ("generate.seed", seed),
        "--workers": ("generate.workers", workers), "--device": ("render.device", device),
        "--object": ("object.mesh", object_), "--spec": ("object.spec", spec), "--backend": ("generate.backend", backend),
        "--address": ("generate.address", address), "--gather": ("generate.gather", gather),
    }, sets=set_).engine(progress).generate(out, overwrite=overwrite, yes=yes)
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
