"""`deformsim bake`: simulate a spec's crush scenarios once into the cached deformation bank."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import console, fail_cleanly


def register(app: typer.Typer) -> None:
    @app.command("bake")
    @fail_cleanly
    def bake_cmd(
        file: Optional[Path] = typer.Argument(None, help="deformation spec YAML (default: the built-in can)"),
        object_: Optional[Path] = typer.Option(None, "--object", help="the mesh the spec is for"),
        force: bool = typer.Option(False, "--force", help="simulate again even when the bank is cached"),
    ) -> None:
        """Simulate every scenario variant of the spec's `simulation:` section (cached by spec, mesh and settings;
        `generate` bakes on first use when deform.sources uses the bank)."""
        from deformsim.bank.stage import bake
        from deformsim.bank.store import load_bank
        from deformsim.generate.stage import check_part
        from deformsim.spec.model import load_spec

        spec = load_spec(file)
        check_part(spec, object_)
        path = bake(spec, file, object_, force=force)
        stats = load_bank(path).stats()
        console.print(f"bank: {stats['entries']} entries ({', '.join(spec.scenario_names)}), simulated in "
                      f"{stats['seconds_total']:.0f} s ({stats['seconds_per_entry']:.1f} s each): {path}")
