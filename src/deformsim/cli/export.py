"""``deformsim export-data``: a dataset variant in a layout other tools read (ImageFolder, COCO, anomalib)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.choices import export_formats, variant_choices
from deformsim.cli.common import console, fail_cleanly, plain_engine


def register(app: typer.Typer) -> None:
    @app.command("export-data")
    @fail_cleanly
    def export_data(
        data: Path = typer.Argument(..., help="generated dataset folder"),
        out: Path = typer.Argument(..., help="new or empty folder for the export"),
        fmt: str = typer.Option(..., "--format", "-f", autocompletion=export_formats,
                                help="imagefolder (torchvision, Hugging Face), coco or anomalib"),
        variant: Optional[str] = typer.Option(
            None, "--variant", autocompletion=variant_choices,
                               help="black, green or a composited variant (default: the first composited one, else black)"
        ),
        overwrite: bool = typer.Option(False, "--overwrite", help="replace an earlier export in OUT (nothing else)"),
        copy: bool = typer.Option(False, "--copy", help="copy the files instead of hard-linking the dataset's own "
                                  "(an export independent of the dataset)"),
        progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while exporting."),
    ) -> None:
        """Export a variant's images (and masks) for torchvision/Hugging Face, COCO tools or anomalib."""
        result = plain_engine(progress).export_data(data, out, fmt, variant, overwrite=overwrite, copy=copy)
        s = result.summary
        copied = s["images"] - s["linked"]
        how = ", ".join(part for part in (f"{s['linked']} hard-linked" if s["linked"] else "",
                                          f"{copied} copied" if copied else "") if part)
        console.print(f"[bold]{s['images']}[/] images of variant {result.variant} exported as {fmt} to {result.out} "
                      f"({how}); see {result.out / 'README.txt'}", highlight=False)
