"""`deformsim config show`: every setting with its description and default, as a YAML file a user can copy."""

from __future__ import annotations

import typer

from deformsim.cli.common import fail_cleanly


def register(app: typer.Typer) -> None:
    config_app = typer.Typer(no_args_is_help=True, help="See every setting of a config.")
    app.add_typer(config_app, name="config")

    @config_app.command("show")
    @fail_cleanly
    def show(
        config: str = typer.Option("quick", "--config", "-c", "--preset", "-p", help="YAML config file or preset name to "
                                    "show"),
    ) -> None:
        """Print every setting with its value, description and default as commented YAML.

        Save it as a file, edit it and pass it with --config; or set one key with --set KEY=VALUE."""
        from deformsim.config import load_config
        from deformsim.config_reference import commented_yaml

        typer.echo(commented_yaml(load_config(config)), nl=False)
