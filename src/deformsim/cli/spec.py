"""`deformsim spec check|preview`: validate a deformation spec, or render what each of its keys does."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.markup import escape

from deformsim.cli.common import ConfigArgs, console, err_console, fail_cleanly


def register(app: typer.Typer) -> None:
    spec_app = typer.Typer(no_args_is_help=True, help="Check or preview a deformation spec.")
    app.add_typer(spec_app, name="spec")

    @spec_app.command("check")
    @fail_cleanly
    def check(
        file: Path = typer.Argument(..., help="deformation spec YAML"),
        object_: Optional[Path] = typer.Option(None, "--object", help="the mesh the spec is for"),
        config: Optional[Path] = typer.Option(None, "--config", help="config YAML or preset whose render size, "
                                              "framing and deform settings decide whether each key shows"),
    ) -> None:
        """Validate a spec (and its mesh) without rendering anything."""
        checked = ConfigArgs(source=config).engine().spec_check(file, object_)
        spec, mesh = checked.spec, ""
        if checked.size is not None:
            mesh = f"; mesh {object_.name}: {' x '.join(f'{v * 1000:.0f}' for v in checked.size)} mm"
        finishes = [spec.material, *spec.material.regions] if spec.material else []
        regions = [r.name + (" (printed)" if r.print else "") for r in finishes[1:]]
        regions_shown = (", printed material" if finishes and finishes[0].print else "") + (
            f", material regions {', '.join(regions)}" if regions else "")
        console.print("[green]ok[/] " + escape(
            f"{file}: '{spec.name}', {len(spec.families)} families, {len(spec.key_names)} keys, "
            f"{len(spec.texture_names)} displacement textures{regions_shown}, "
            f"lattice {'x'.join(map(str, spec.lattice.points))}{mesh}"
        ))
        if checked.hint:
            err_console.print(f"[yellow]hint:[/] {checked.hint}", highlight=False, soft_wrap=True)
        if checked.small:
            err_console.print(f"[yellow]warning:[/] {checked.small}", highlight=False, soft_wrap=True)

    @spec_app.command("preview")
    @fail_cleanly
    def preview(
        file: Optional[Path] = typer.Argument(None, help="deformation spec YAML (default: the built-in can)"),
        object_: Optional[Path] = typer.Option(None, "--object", help="the mesh the spec is for"),
        out: Path = typer.Option(Path("spec_preview.png"), "--out", "-o", help="PNG to write"),
        resolution: int = typer.Option(192, help="tile size in pixels"),
        samples: int = typer.Option(16, help="Cycles samples per pixel"),
        no_bank: bool = typer.Option(False, "--no-bank", help="Render the lattice keys, textures and openings "
                                     "alone: no simulated bank tiles, so no bank to bake first."),
        progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while it renders."),
        config: Optional[Path] = typer.Option(None, "--config", help="config YAML or preset of the run, whose render "
                                              "size, framing and deform settings decide whether each key shows"),
    ) -> None:
        """Render the rest shape and each key at full weight into one labelled image."""
        sizes = ConfigArgs(flags={"--resolution": ("render.resolution", resolution),
                                  "--samples": ("render.samples", samples)})
        sizes.engine(progress)  # the sizes within the config's ranges
        engine = ConfigArgs(source=config).engine(progress)  # the run's settings, for the small-key warning
        path = engine.spec_preview(file, object_, out, resolution, samples, bank=not no_bank)
        console.print(f"spec preview: {path}")
