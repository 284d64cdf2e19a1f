"""What every command shares: exit codes, the error reporter, stderr messages, `--set` parsing,
and the placement options of `plan` and `report` (defined once here)."""

from __future__ import annotations

import sys
import tomllib
from contextlib import contextmanager
from typing import Annotated, Optional

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


PLACEMENT_HELP = (
    "Pose files (--camera-pose, NAME.pose.json, frames of --frames) hold exactly one of "
    '{"T_base_camera": 4x4 row-major, camera -> base, m}, {"flange_pose": [x,y,z,rx,ry,rz]} (UR pose '
    'vector of tool0, m and rad) or {"joints_rad": [q1..q6]}, and optionally "robot": ur5 (the default), ur5e '
    "or ur10 for the joint angles; any other key is refused. A hand-eye file is "
    '{"setup": "eye-in-hand", "T_flange_camera": 4x4} or {"setup": "eye-to-hand", "T_base_camera": 4x4}. '
    'A frames manifest is {"hand_eye": "H.json", "frames": [{"scan": "a.png", "intrinsics": "d415.json", '
    '"joints_rad": [...]}, {"scan": "b.png", "pose": "b.pose.json"}]} (paths relative to it).\n\n'
    "A scan without a pose option is placed by NAME.pose.json beside it (else pose.json), and a depth image "
    "without --intrinsics reads NAME.intrinsics.json (else intrinsics.json), as batch does; each is said on "
    "stderr and recorded. Without any pose, camera-frame data stays in the camera frame and the path JSON says "
    '"frame": "camera". A path JSON given as --config (or the path a report is drawn for) places the scan it '
    "was made from as it was then (pose, intrinsics, cloud frame, units, camera origin), unless an option says "
    "otherwise."
)

# The placement options: where the scans are and how they sit in the robot base frame. `plan`
# and `report` take the same ones; weldseam.io.placement resolves them (None: not given).
Scans = Annotated[
    Optional[list[str]],
    typer.Argument(
        help="Scan: .ply .pcd .xyz .txt .npy, a 16-bit depth .png, or - (PLY on stdin). Several scans are "
        "frames of one workpiece, each with its pose in NAME.pose.json beside it.",
        show_default=False,
    ),
]
FramesOption = Annotated[
    Optional[str],
    typer.Option("--frames", help="Frames manifest JSON: several scans of one workpiece with their poses."),
]
IntrinsicsOption = Annotated[
    Optional[str],
    typer.Option("--intrinsics", help="Intrinsics JSON for a depth image (default: NAME.intrinsics.json beside it)."),
]
CameraPoseOption = Annotated[
    Optional[str],
    typer.Option(
        "--camera-pose",
        help='Pose file: {"T_base_camera": 4x4 row-major}, or a robot state (default: NAME.pose.json beside the '
        "scan, else pose.json).",
    ),
]
FlangePoseOption = Annotated[
    Optional[str],
    typer.Option(
        "--flange-pose", help="Flange (tool0) pose at capture x,y,z,rx,ry,rz (m, rotation vector); needs --hand-eye."
    ),
]
JointsOption = Annotated[
    Optional[str], typer.Option("--joints", help="Joint angles at capture q1,...,q6 (rad); needs --hand-eye.")
]
HandEyeOption = Annotated[
    Optional[str], typer.Option("--hand-eye", help="Hand-eye calibration JSON (eye-in-hand or eye-to-hand).")
]
RobotOption = Annotated[
    Optional[str],
    typer.Option("--robot", help='Robot the joint angles are of: ur5, ur5e or ur10 (default: the pose\'s "robot", '
                 "else ur5)."),
]
CloudFrameOption = Annotated[
    Optional[str], typer.Option("--cloud-frame", help="Frame of a cloud file: base or camera (default base).")
]
CameraOriginOption = Annotated[
    Optional[str],
    typer.Option("--camera-origin", help="Camera centre x,y,z in the base frame (m), to orient normals."),
]
UnitsOption = Annotated[Optional[str], typer.Option("--units", help="Units of a cloud file: m or mm (default m).")]
