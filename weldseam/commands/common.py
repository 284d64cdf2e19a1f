"""What every command shares: exit codes, the error reporter, stderr messages, `--set` parsing."""

from __future__ import annotations

import sys
import tomllib
from contextlib import contextmanager

import typer

from weldseam.errors import (
    InputError,
    NoSeamError,
    RobotConnectionError,
    RobotFault,
    StageError,
    UnreachableError,
    WeldseamError,
)

EXIT_CODES = (
    (0, "success"),
    (1, "differences found (compare) or some batch items failed"),
    (2, "usage error, or unreadable / invalid input"),
    (3, "no weld seam found"),
    (4, "a pose is unreachable (refused before any motion)"),
    (5, "robot fault (the robot was stopped)"),
    (6, "could not connect to the robot (nothing moved)"),
    (70, "internal error (a bug: please report it with the input)"),
    (129, "hung up (SIGHUP; batch stops its workers and keeps what finished)"),
    (130, "interrupted (Ctrl-C)"),
    (143, "terminated (SIGTERM; batch stops its workers and keeps what finished)"),
)
EXIT_ROBOT_FAULT = 5
EXIT_FOR = (
    (InputError, 2),
    (NoSeamError, 3),
    (UnreachableError, 4),
    (RobotFault, EXIT_ROBOT_FAULT),
    (RobotConnectionError, 6),
    (StageError, 70),
)
EXIT_TABLE = "\n\n".join(f"{code}: {meaning}" for code, meaning in EXIT_CODES)


def stderr(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


@contextmanager
def reported():
    """Turn library exceptions into one `Error: ...` line on stderr and the documented exit code."""
    try:
        yield
    except WeldseamError as error:
        stderr(f"Error: {error}")
        code = next((code for kind, code in EXIT_FOR if isinstance(error, kind)), 70)
        raise typer.Exit(code) from None
    except KeyboardInterrupt:
        stderr("Error: interrupted")
        raise typer.Exit(130) from None


def parse_settings(settings: list[str]) -> dict[str, dict]:
    """Parse `section.key=value` (value in TOML syntax: 0.004, true, "thesis", [0, 0, 0])."""
    overrides: dict[str, dict] = {}
    for setting in settings:
        name, separator, text = setting.partition("=")
        section, dot, key = name.strip().partition(".")
        if not separator or not dot or not key:
            raise InputError(f"--set {setting!r}: expected section.key=value, e.g. normals.radius_m=0.008")
        try:
            value = tomllib.loads(f"value = {text.strip()}")["value"]
        except tomllib.TOMLDecodeError:
            value = text.strip()
        overrides.setdefault(section, {})[key] = value
    return overrides


def command_overrides(settings: list[str] | None, fmt: str | None, rotation: str | None) -> dict[str, dict]:
    """`--set` values plus the `--format` and `--rotation` options, as config overrides."""
    overrides = parse_settings(settings or [])
    if fmt is not None:
        overrides.setdefault("output", {})["format"] = fmt
    if rotation is not None:
        overrides.setdefault("output", {})["rotation"] = rotation
    return overrides
