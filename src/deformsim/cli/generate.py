"""`deformsim generate`: render a labelled intact/deformed dataset."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import ConfigArgs, console, fail_cleanly, set_option, shortcut, shortcut_flags, yes_option


def generate(
    out: Path = typer.Option(..., "--out", "-o", help="output folder (rerun to resume)"),
    config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
    n: Optional[int] = shortcut("--n"),
    resolution: Optional[int] = shortcut("--resolution"),
    samples: Optional[int] = shortcut("--samples"),
    seed: Optional[int] = shortcut("--seed"),
    workers: Optional[int] = shortcut("--workers"),
    device: Optional[str] = shortcut("--device"),
    object_: Optional[Path] = shortcut("--object"),
    spec: Optional[Path] = shortcut("--spec"),
    backend: Optional[str] = shortcut("--backend"),
    address: Optional[str] = shortcut("--address"),
    gather: Optional[bool] = shortcut("--gather"),
    overwrite: bool = typer.Option(
        False, "--overwrite", help="replace a dataset in --out made with other settings, inputs or more images"
    ),
    yes: bool = yes_option(),
    set_: list[str] = set_option(),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while rendering."),
) -> None:
    """Render a balanced, labelled intact/deformed dataset with Blender.

    Rerunning on the same folder resumes, or extends it with a larger --n. A folder rendered with other
    settings, another mesh or spec content, or more images than --n is refused unless --overwrite is given,
    which removes it as a whole and renders anew. More than 100000 images print their estimated time and
    disk and stop unless --yes is given."""
    flags = shortcut_flags(n=n, resolution=resolution, samples=samples, seed=seed, workers=workers, device=device,
                           object_=object_, spec=spec, backend=backend, address=address, gather=gather)
    result = ConfigArgs(config, flags, sets=set_).engine(progress).generate(out, overwrite=overwrite, yes=yes)
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
