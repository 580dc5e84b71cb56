"""`deformsim spec check|preview`: validate a deformation spec, or render what each of its keys does."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.common import console, err_console, fail_cleanly


def register(app: typer.Typer) -> None:
    spec_app = typer.Typer(no_args_is_help=True, help="Check or preview a deformation spec.")
    app.add_typer(spec_app, name="spec")

    @spec_app.command("check")
    @fail_cleanly
    def check(
        file: Path = typer.Argument(..., help="deformation spec YAML"),
        object_: Optional[Path] = typer.Option(None, "--object", help="the mesh the spec is for"),
    ) -> None:
        """Validate a spec (and its mesh) without rendering anything."""
        from deformsim.generate.probe import probe_mesh
        from deformsim.spec.model import check_mesh_file, load_spec, units_hint

        spec = load_spec(file)
        mesh, hint = "", None
        if object_ is not None:
            check_mesh_file(object_)
            size = probe_mesh(object_, file)["size"]
            mesh = f"; mesh {object_.name}: {' x '.join(f'{v * 1000:.0f}' for v in size)} mm"
            hint = units_hint(size, spec)
        console.print(
            f"[green]ok[/] {file}: '{spec.name}', {len(spec.families)} families, {len(spec.key_names)} keys, "
            f"{len(spec.texture_names)} displacement textures, lattice {'x'.join(map(str, spec.lattice.points))}{mesh}"
        )
        if hint:
            err_console.print(f"[yellow]hint:[/] {hint}", highlight=False, soft_wrap=True)

    @spec_app.command("preview")
    @fail_cleanly
    def preview(
        file: Optional[Path] = typer.Argument(None, help="deformation spec YAML (default: the built-in can)"),
        object_: Optional[Path] = typer.Option(None, "--object", help="the mesh the spec is for"),
        out: Path = typer.Option(Path("spec_preview.png"), "--out", "-o", help="PNG to write"),
        resolution: int = typer.Option(192, help="tile size in pixels"),
        samples: int = typer.Option(16, help="Cycles samples per pixel"),
    ) -> None:
        """Render the rest shape and each key at full weight into one labelled image."""
        from deformsim.generate.spec_preview import render_preview
        from deformsim.outputs import check_file_target

        check_file_target(out, "--out")  # before rendering

        path = render_preview(file, object_, out, resolution, samples)
        console.print(f"spec preview: {path}")
