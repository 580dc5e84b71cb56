"""`deformsim bake`: simulate a spec's crush scenarios once into the cached deformation bank."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import console, fail_cleanly, plain_engine


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
        from deformsim.bank.store import load_bank

        path = plain_engine(overrides={"object.spec": file, "object.mesh": object_}).bake(force=force)
        bank = load_bank(path)
        stats = bank.stats()
        scenarios = dict.fromkeys(name.rsplit("/", 1)[0] for name in bank.names)
        console.print(f"bank: {stats['entries']} entries ({', '.join(scenarios)}), simulated in "
                      f"{stats['seconds_total']:.0f} s ({stats['seconds_per_entry']:.1f} s each): {path}")
