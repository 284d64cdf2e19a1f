"""`weldseam calibrate hand-eye`: where the camera sits on (or over) the robot, from images of a board."""

from __future__ import annotations

import json
import math
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer

from weldseam.commands.common import EXIT_TABLE, reported, stderr
from weldseam.errors import InputError

MANIFEST_HELP = (
    "Manifest (JSON; file names relative to it; lengths of the board in mm):\n\n"
    "\b\n"
    '  {"setup": "eye-in-hand",          (or "eye-to-hand")\n'
    '   "intrinsics": "intrinsics.json", (width height fx fy cx cy; ppx/ppy too)\n'
    '   "distortion": [k1, k2, p1, p2, k3],   (optional, OpenCV order)\n'
    '   "robot": "ur5",                  (optional: ur5 ur5e ur10, for joints_rad)\n'
    '   "board": {"type": "chessboard", "columns": 9, "rows": 6,\n'
    '             "square_mm": 25},\n'
    '     or     {"type": "charuco", "squares_x": 7, "squares_y": 5,\n'
    '             "square_mm": 30, "marker_mm": 22, "dictionary": "DICT_5X5_100"},\n'
    '   "captures": [\n'
    '     {"image": "cap01.png", "flange_pose": [x, y, z, rx, ry, rz]},\n'
    '     {"image": "cap02.png", "joints_rad": [q1, q2, q3, q4, q5, q6]}]}\n\n'
    "columns x rows counts a chessboard's inner corners (one even, one odd). flange_pose is the UR pose vector of "
    "tool0 (the flange, not a TCP: zero the TCP offset, or use get_actual_tool_flange_pose()) in the base frame "
    "at capture time (metres, rotation vector); joints_rad are the joint angles instead (forward kinematics).\n\n"
    "Output: eye-in-hand writes T_flange_camera (camera points -> tool0 frame), eye-to-hand T_base_camera "
    "(camera points -> base frame), 4x4 row-major, metres, with the method and its residuals. "
    "leave_one_out is the estimated error of the transform: it is solved again without each capture in turn, "
    "and the spread of those answers (jackknife, mm and deg) tracks the true error (on 360 synthetic runs the "
    "true error was below twice it in 97 % and below three times it in all). board_scatter is how much the fixed board pose scatters "
    "over the captures (centre mm, rotation deg, corners mm): what the solver minimised, not an error estimate. "
    "--method auto keeps the method whose board corners scatter least."
)
EPILOG = (
    "Example:\n\n"
    "\b\n"
    "  python -m weldseam.synthetic.board calib    # a synthetic capture set\n"
    "  weldseam calibrate hand-eye calib/manifest.json -o hand_eye.json\n"
    "  weldseam calibrate hand-eye calib/manifest.json -o H.json --json > table.json\n\n"
    f"{MANIFEST_HELP}\n\n"
    "Take 10-20 captures with the whole board in view, tilting the flange by 15-30 deg about different axes. "
    "Refused, before any image is read: fewer than 6 captures; captures whose flange orientations differ by "
    "less than 10 deg, or turn about one axis only (all motion axes within 5 deg of one line); and a set that "
    "breaks either rule once any one capture is left out (that capture could not be checked).\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)
calibrate_app = typer.Typer(
    help="Calibrate the camera against the robot.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,
)


@calibrate_app.command("hand-eye", epilog=EPILOG)
def hand_eye(
    manifest: Annotated[str, typer.Argument(help="Capture manifest (JSON), see below.")],
    output: Annotated[str, typer.Option("--output", "-o", help="Hand-eye JSON to write, or - for stdout.")],
    method: Annotated[
        str, typer.Option(help="auto (least board scatter), tsai, park, horaud, andreff or daniilidis.")
    ] = "auto",
    as_json: Annotated[bool, typer.Option("--json", help="Print the residual table as JSON on stdout.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No table or summary on stderr.")] = False,
) -> None:
    """Solve the hand-eye transform (AX = XB) from images of a calibration board and the robot pose at each."""
    with reported():
        import numpy as np

        from weldseam.calibration.board import detect_board, estimate_board_pose
        from weldseam.calibration.handeye import METHODS, calibrate_hand_eye, check_rotation_diversity
        from weldseam.calibration.manifest import read_image, read_manifest
        from weldseam.io.atomic import atomic_write

        if output == "-" and as_json:
            raise InputError("-o - and --json both want stdout; write the hand-eye file to a path")
        if method != "auto" and method not in METHODS:
            raise InputError(f"--method {method}: expected auto, {', '.join(METHODS)}")
        spec = read_manifest(Path(manifest))
        flange_poses = np.array([capture.flange_pose for capture in spec.captures]).reshape(-1, 4, 4)
        # Too few or too similar captures are refused before any image is read.
        with _about(manifest):
            check_rotation_diversity(flange_poses, spec.setup)
        poses = []
        for number, capture in enumerate(spec.captures, start=1):
            image = read_image(capture.image, spec.width, spec.height)
            view = detect_board(image, spec.board)
            if view is None:
                raise InputError(
                    f"{capture.image} (capture {number}): {spec.board.describe()} not found in the image "
                    "(the whole board must be in view, sharp and not too oblique)"
                )
            with _about(f"{capture.image} (capture {number})"):
                poses.append(estimate_board_pose(view, spec.camera, spec.distortion))
        with _about(manifest):
            result = calibrate_hand_eye(flange_poses, np.array([pose.T_camera_board for pose in poses]), spec.setup,
                                        spec.board.corners_m, method=method)  # fmt: skip
        text = json.dumps(result.to_dict(), indent=2) + "\n"
        if output == "-":
            sys.stdout.write(text)
        else:
            atomic_write(output, text.encode())
        reprojection_px = max(pose.reprojection_px for pose in poses)
        if as_json:
            print(json.dumps(_table_dict(result, reprojection_px), indent=2))
        elif not quiet:
            _print_table(result)
        if not quiet:
            error, scatter = result.chosen.error, result.chosen.scatter
            stderr(
                f"{'stdout' if output == '-' else output}: {result.setup}, {result.method}, {result.captures} "
                f"captures; estimated error {error.translation_mm:.2f} mm / {error.rotation_deg:.3f} deg "
                f"(leave-one-out); board scatter {scatter.translation_mm:.2f} mm / {scatter.rotation_deg:.3f} deg; "
                f"reprojection <= {reprojection_px:.2f} px"
            )


@contextmanager
def _about(source: str):
    """Prefix an InputError's message with the file (and capture) it is about."""
    try:
        yield
    except InputError as error:
        raise InputError(f"{source}: {error}") from None


def _table_rows(result) -> list[tuple[str, ...]]:
    def cell(value: float, digits: int) -> str:
        return f"{value:.{digits}f}" if math.isfinite(value) else "failed"

    return [
        (
            entry.method,
            cell(entry.error.translation_mm, 3),
            cell(entry.error.rotation_deg, 4),
            cell(entry.scatter.translation_mm, 3),
            cell(entry.scatter.rotation_deg, 4),
            cell(entry.scatter.corners_mm, 3),
            "<- chosen" if entry.method == result.method else "",
        )
        for entry in result.per_method
    ]


def _table_dict(result, reprojection_px: float) -> dict:
    """The residual table as JSON: every method's leave-one-out error and board scatter, the chosen one flagged."""
    document = result.to_dict()
    return {
        "setup": result.setup,
        "method": result.method,
        "captures": result.captures,
        "max_reprojection_px": round(reprojection_px, 6),
        "methods": [
            {"method": name, **residuals, "chosen": name == result.method}
            for name, residuals in document["residuals"]["per_method"].items()
        ],
    }


def _print_table(result) -> None:
    """Each method's leave-one-out error and board scatter on stderr: a rich table on a terminal, aligned text
    otherwise."""
    header = ("method", "error mm", "error deg", "scatter mm", "scatter deg", "corners mm", "")
    rows = _table_rows(result)
    if sys.stderr.isatty():
        from rich.console import Console
        from rich.table import Table

        table = Table(title="estimated error (leave-one-out) and board scatter over the captures (RMS)")
        for k, name in enumerate(header):
            table.add_column(name, justify="left" if k in (0, 6) else "right")
        for row in rows:
            table.add_row(*row, style="bold" if row[-1] else None)
        Console(stderr=True).print(table)
        return
    widths = [max(len(header[k]), *(len(row[k]) for row in rows)) for k in range(len(header))]
    for row in (header, *rows):
        stderr("  ".join(cell.ljust(width) if k in (0, 6) else cell.rjust(width)
                         for k, (cell, width) in enumerate(zip(row, widths))).rstrip())  # fmt: skip
