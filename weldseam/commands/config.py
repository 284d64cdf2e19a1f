"""`weldseam config show`: the effective configuration as TOML, to start a config file from."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from weldseam.commands.common import EXIT_TABLE, parse_settings, reported

EPILOG = (
    "Example:\n\n"
    "  weldseam config show > weldseam.toml\n\n"
    "  weldseam config show --config weldseam.toml --set normals.radius_m=0.008\n\n"
    "  weldseam plan scan.ply --config weldseam.toml -o path.json\n\n"
    "Precedence: command-line options > --config FILE > defaults.\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)

app = typer.Typer(
    help="Show the effective configuration (every pipeline and output parameter).",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,
)


@app.command("show", epilog=EPILOG)
def show(
    config_file: Annotated[
        Optional[str],
        typer.Option("--config", help="TOML config file, or a path JSON whose params to show."),
    ] = None,
    settings: Annotated[
        Optional[list[str]],
        typer.Option("--set", help="Override a parameter: section.key=value (repeatable)."),
    ] = None,
) -> None:
    """Print the effective configuration as TOML on stdout."""
    with reported():
        from weldseam.config import config_to_toml, effective_config

        print(config_to_toml(effective_config(config_file, parse_settings(settings or []))), end="")
