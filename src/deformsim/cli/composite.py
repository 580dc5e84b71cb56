"""`deformsim composite`: matte a generated dataset and put it on backgrounds, as a named variant."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.choices import config_choices
from deformsim.cli.common import ConfigArgs, console, err_console, fail_cleanly, set_option


def register(app: typer.Typer) -> None:
    @app.command("composite")
    @fail_cleanly
    def composite(
        out: Path = typer.Argument(..., help="generated dataset folder"),
        backgrounds: Optional[Path] = typer.Option(
            None, "--backgrounds", "-b", help="folder of photos, searched recursively (default: procedural)"
        ),
        name: Optional[str] = typer.Option(
            None, "--name", help="variant name (default: 'backgrounds' with a folder, else 'procedural')"
        ),
        matte: Optional[str] = typer.Option(
            None, "--matte", autocompletion=config_choices("composite.matte"),
                             help="chroma (soft green key), alpha (exact render alpha), inrange (the paper's key)"
        ),
        seed: int = typer.Option(0, "--seed", help="seed of every background choice, crop and flip"),
        workers: Optional[int] = typer.Option(None, "--workers", help="processes (0 = automatic)"),
        config: Optional[str] = typer.Option(
            None, "--config", "-c", help="YAML config or preset (default: the dataset's config.yaml)"
        ),
        set_: list[str] = set_option(),
        progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while compositing."),
    ) -> None:
        """Composite every image onto photo or procedural backgrounds (chroma key or exact alpha)."""
        import warnings
        from statistics import mean

        from deformsim.composite.backgrounds import BackgroundWarning
        from deformsim.dataset.layout import Layout

        own = Layout(out).config
        engine = ConfigArgs(config or (str(own) if own.is_file() else None), {
            "--backgrounds": ("composite.backgrounds", str(backgrounds) if backgrounds else None),
            "--matte": ("composite.matte", matte), "--workers": ("composite.workers", workers),
        }, sets=set_).engine(progress)
        with warnings.catch_warnings():
            warnings.simplefilter("always", BackgroundWarning)
            warnings.showwarning = lambda message, *a, **k: err_console.print(
                f"[yellow]warning:[/] {message}", highlight=False, soft_wrap=True
            )
            made = engine.composite(out, name, seed)
        iou = made.matte_iou
        quality = f"; matte IoU vs exact alpha: mean {mean(iou):.4f}, min {min(iou):.4f}" if iou else ""
        shown = f", {made.surfaces} of them rendered surface scenes" if made.surfaces else ""
        console.print(f"[bold]{made.images}[/] composites ({engine.config.composite.matte} matte{shown}) in "
                      f"{made.folder}{quality}")
