"""`deformsim show`: a contact sheet of a dataset variant, and of its dense maps, to judge it at a glance."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.choices import variant_choices
from deformsim.cli.common import console, fail_cleanly


def register(app: typer.Typer) -> None:
    @app.command("show")
    @fail_cleanly
    def show(
        data: Path = typer.Argument(..., help="Generated dataset folder."),
        variant: str = typer.Option(..., "--variant", autocompletion=variant_choices,
                                    help="The variant: black, green, rgba or a composited one."),
        out: Optional[Path] = typer.Option(None, "--out", "-o",
                                           help="PNG to write (default: VARIANT_sheet.png, or VARIANT_dense.png)."),
        dense: bool = typer.Option(False, "--dense", help="One row per image: it, then its mask, depth, normal, "
                                   "deform and region maps."),
        count: int = typer.Option(8, "--count", min=1, max=200, help="How many images, half of each label."),
        seed: int = typer.Option(0, "--seed", help="Which images: the same seed shows the same ones."),
    ) -> None:
        """Write a contact sheet of a variant's images (with --dense, of its dense maps beside them)."""
        from deformsim.atomic import atomic_path
        from deformsim.dataset.contact_sheet import variant_sheet
        from deformsim.dataset.variants import variant_table
        from deformsim.outputs import check_file_target

        out = check_file_target(out or Path(f"{variant}_{'dense' if dense else 'sheet'}.png"), "--out")
        sheet = variant_sheet(variant_table(data, variant), count, seed, dense)
        with atomic_path(out) as tmp:
            sheet.save(tmp, format="PNG")
        console.print(f"sheet of {variant}: {out}", highlight=False)
