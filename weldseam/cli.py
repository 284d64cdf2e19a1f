"""The `weldseam` command line: the Typer app and its commands (each in `weldseam/commands/`)."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from weldseam import __version__
from weldseam.commands import batch, calibrate, compare, config, plan, report, robot, robot_sim
from weldseam.commands.common import EXIT_TABLE

app = typer.Typer(
    name="weldseam",
    help="Turn a 3D scan of a grooved workpiece into an ordered 6-DOF robot welding path.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,
    epilog=f"Exit codes:\n\n{EXIT_TABLE}",
)
app.command("plan", epilog=plan.EPILOG)(plan.plan)
app.command("check", epilog=robot.CHECK_EPILOG)(robot.check)
app.command("send", epilog=robot.SEND_EPILOG)(robot.send)
app.command("robot-sim", epilog=robot_sim.EPILOG)(robot_sim.robot_sim)
app.command("batch", epilog=batch.EPILOG)(batch.batch)
app.command("compare", epilog=compare.EPILOG)(compare.compare)
app.command("report", epilog=report.EPILOG)(report.report)
app.add_typer(config.app, name="config")
app.add_typer(calibrate.calibrate_app, name="calibrate")


def _version(value: bool) -> None:
    if value:
        print(f"weldseam {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[
        Optional[bool],
        typer.Option(
            "--version",
            callback=_version,
            is_eager=True,
            help="Print the version and exit.",
        ),
    ] = None,
) -> None:
    """Turn a 3D scan of a grooved workpiece into an ordered 6-DOF robot welding path."""


def main() -> None:
    """Console entry point."""
    app()


if __name__ == "__main__":
    main()
