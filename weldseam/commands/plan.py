"""`weldseam plan`: one scan in, the ordered torch path out."""

from __future__ import annotations

import itertools
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import typer

from weldseam.commands.common import (
    EXIT_TABLE,
    PLACEMENT_HELP,
    CameraOriginOption,
    CameraPoseOption,
    CloudFrameOption,
    FlangePoseOption,
    FramesOption,
    HandEyeOption,
    IntrinsicsOption,
    JointsOption,
    RobotOption,
    Scans,
    UnitsOption,
    command_overrides,
    reported,
    stderr,
)
from weldseam.errors import InputError, NoSeamError

EPILOG = (
    "Example:\n\n"
    "  weldseam plan samples/v_butt.ply --camera-origin 0.02,-0.1,0.45 -o path.json\n\n"
    "  weldseam plan depth.png --intrinsics d415.json --camera-pose pose.json -o - --format csv\n\n"
    "  weldseam plan depth.png --intrinsics d415.json --joints 0,-1.57,1.57,-1.57,-1.57,0 --hand-eye H.json\n\n"
    "  weldseam plan left.png top.png right.png --intrinsics d415.json --hand-eye H.json -o path.json\n\n"
    "  (several frames of one workpiece: left.pose.json, top.pose.json, right.pose.json beside them)\n\n"
    "  weldseam plan --frames frames.json -o path.json\n\n"
    "  weldseam plan scan.ply --direction away-from-robot -o path.json   (or --direction=-y, or a point x,y,z)\n\n"
    "  weldseam plan scan.ply --config path.json -o again.csv   (reruns path.json's run on its own scan)\n\n"
    f"{PLACEMENT_HELP}\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)


def plan(
    scans: Scans = None,
    frames: FramesOption = None,
    output: Annotated[
        str,
        typer.Option("--output", "-o", help="Path file (.json or .csv), or - for stdout."),
    ] = "-",
    fmt: Annotated[
        Optional[str],
        typer.Option("--format", help="json or csv (default: from the extension; csv on stdout)."),
    ] = None,
    rotation: Annotated[
        Optional[str], typer.Option(help="CSV rotation columns: rotvec (UR rx,ry,rz, the default) or quat.")
    ] = None,
    intrinsics: IntrinsicsOption = None,
    camera_pose: CameraPoseOption = None,
    flange_pose: FlangePoseOption = None,
    joints: JointsOption = None,
    hand_eye: HandEyeOption = None,
    robot: RobotOption = None,
    cloud_frame: CloudFrameOption = None,
    camera_origin: CameraOriginOption = None,
    units: UnitsOption = None,
    crop: Annotated[
        Optional[str],
        typer.Option(help="Keep only points in the box x0,y0,z0,x1,y1,z1 (base frame, m)."),
    ] = None,
    threshold: Annotated[Optional[float], typer.Option(help="Descriptor threshold (default: automatic).")] = None,
    spacing_mm: Annotated[
        Optional[float],
        typer.Option(help="Pose spacing along the seam, mm (default 2)."),
    ] = None,
    direction: Annotated[
        Optional[str],
        typer.Option(
            help="Travel direction: +x -x +y -y +z -z (base axes; write --direction=-x), away-from-robot, "
            "toward-robot, or a start point x,y,z (m: each seam starts at its end nearest it). Default +x.",
        ),
    ] = None,
    config_file: Annotated[
        Optional[str],
        typer.Option(
            "--config",
            help="TOML config file (see `weldseam config show`), or a path JSON: its parameters, and for the scan "
            "it was made from its placement too (reruns that run).",
        ),
    ] = None,
    settings: Annotated[
        Optional[list[str]],
        typer.Option("--set", help="Override a parameter: section.key=value (repeatable)."),
    ] = None,
    allow_empty: Annotated[bool, typer.Option(help="No seam found: write an empty path and exit 0.")] = False,
    dump_stages: Annotated[
        Optional[Path],
        typer.Option(help="Write each stage's points as PLY into this folder."),
    ] = None,
    report: Annotated[
        Optional[str],
        typer.Option(help="Also write a report of the result: .html (interactive, offline) or .png."),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No messages on stderr except errors.")] = False,
    verbose: Annotated[
        bool, typer.Option("--verbose", "-v", help="Per-step timings and every seam candidate with its fate, on stderr.")
    ] = False,
) -> None:
    """Find the weld seams in a scan and write the ordered torch path."""
    with reported():
        from weldseam.config import effective_config
        from weldseam.io.atomic import check_writable, prepare_folder
        from weldseam.io.clouds import write_ply
        from weldseam.io.paths import path_format, write_paths
        from weldseam.io.placement import PlacementOptions, place_scans, read_recorded, with_placement
        from weldseam.io.poses import parse_vector
        from weldseam.pipeline.frames import plan_frames
        from weldseam.pipeline.run import plan_paths

        overrides = command_overrides(settings, fmt, rotation)
        if threshold is not None:
            overrides.setdefault("segment", {})["threshold"] = threshold
        if spacing_mm is not None:
            if spacing_mm <= 0:
                raise InputError(f"--spacing-mm must be positive, got {spacing_mm:g}")
            overrides.setdefault("resample", {})["spacing_m"] = spacing_mm / 1000.0
        if crop is not None:
            box = parse_vector(crop, 6, "--crop")
            if (box[:3] >= box[3:]).any():
                raise InputError(f"--crop: each lower corner value must be below the upper one, got {crop}")
            overrides.setdefault("condition", {}).update(crop_min_m=box[:3].tolist(), crop_max_m=box[3:].tolist())
        if direction is not None:
            overrides["direction"] = _direction_rule(direction)
        config = effective_config(config_file, overrides)
        # Every output is checked before any work: a bad name must not cost a whole run.
        path_fmt = path_format(output, None if config.output.format == "auto" else config.output.format)
        if output != "-":
            check_writable(output)
        if report is not None:
            if not report.lower().endswith((".html", ".png")):
                raise InputError(f"--report {report}: the report is a .html or a .png file")
            check_writable(report)
        if dump_stages is not None:
            prepare_folder(dump_stages)
        started = time.perf_counter()
        placement = PlacementOptions(
            tuple(scans or ()), frames, intrinsics, camera_pose, flange_pose, joints, hand_eye, robot,
            cloud_frame, camera_origin, units,
        )
        placed = place_scans(placement, read_recorded(config_file) if config_file is not None else None)
        if not quiet:
            for message in placed.messages:
                stderr(message)
        stages: dict[str, tuple] = {}
        counter = itertools.count()

        def dump(stage: str, points, values) -> None:
            if report is not None:
                stages.setdefault(stage, (points, values))
            if dump_stages is not None:
                write_ply(dump_stages / f"{next(counter):03d}_{stage}.ply", points, values=values)

        with _progress(enabled=not quiet) as on_stage, _hinted(placed.hints), _candidates_shown(verbose and not quiet):
            if len(placed.frames) > 1:
                result = plan_frames(
                    placed.frames, config, source=placed.source, dump=dump, on_stage=on_stage, allow_empty=allow_empty
                )
            else:
                result = plan_paths(placed.frames[0], config, dump=dump, on_stage=on_stage, allow_empty=allow_empty)
        result = with_placement(result, placed)
        write_paths(result, output, fmt=path_fmt, rotation=config.output.rotation)
        if report is not None:
            _write_report(report, placed.merged(), result, stages)
        if not quiet:
            for message in result.warnings:
                stderr(f"Warning: {message}")
            _report(result, output, time.perf_counter() - started, verbose)


def _direction_rule(text: str) -> dict:
    """The `[direction]` overrides of --direction: a rule name, or a start point x,y,z (m)."""
    from weldseam.config import DIRECTION_RULES
    from weldseam.io.poses import parse_vector

    names = [rule for rule in DIRECTION_RULES if rule != "start-point"]
    if text in names:
        return {"rule": text, "start_m": None}
    try:
        point = parse_vector(text, 3, "--direction")
    except InputError:
        raise InputError(f"--direction: expected {', '.join(names)} or a start point x,y,z (m), got {text!r}") from None
    return {"rule": "start-point", "start_m": point.tolist()}


def _write_report(target: str, scan, result, stages: dict) -> None:
    import json

    from weldseam.io.paths import format_path_json
    from weldseam.report import write_report

    html, png = (target, None) if target.lower().endswith(".html") else (None, target)
    candidates = stages.get("segment", (None, None))[0]
    record = json.loads(format_path_json(result))
    write_report(scan.points_m, list(result.paths), record, html, png, scan_name=scan.source, candidates_m=candidates)


@contextmanager
def _hinted(hints: tuple[str, ...]):
    """A "no weld seam found" says what may be wrong with the inputs, when something looks so."""
    try:
        yield
    except NoSeamError as error:
        if not hints:
            raise
        raise NoSeamError(f"{error}; {'; '.join(hints)}", error.candidates) from None


@contextmanager
def _progress(enabled: bool):
    """A spinner naming the running stage, on a terminal only (pipes and CI get none)."""
    if not (enabled and sys.stderr.isatty()):
        yield None
        return
    from rich.console import Console

    with Console(stderr=True).status("planning") as status:
        yield lambda stage: status.update(f"planning: {stage}")


def _report(result, output: str, seconds: float, verbose: bool) -> None:
    if verbose:
        for name, spent in result.timings_s.items():
            stderr(f"  {name:<11} {spent * 1000:8.1f} ms")
        _print_candidates(result.candidates)
    for path in result.paths:
        stderr(
            f"seam {path.seam_id}: {path.joint}, {'closed, ' if path.closed else ''}{path.length_m * 1000:.1f} mm, "
            f"{len(path.positions_m)} poses, confidence {path.confidence:.2f}"
        )
    target = "stdout" if output == "-" else output
    stderr(f"{len(result.paths)} seam(s) in {seconds:.2f} s -> {target}")


@contextmanager
def _candidates_shown(enabled: bool):
    """With -v, when no seam is found, every candidate and why it was rejected before the error."""
    from weldseam.errors import NoSeamError

    try:
        yield
    except NoSeamError as error:
        if enabled:
            _print_candidates(error.candidates)
        raise


def _print_candidates(candidates) -> None:
    """One line per seam candidate: where it lies (mm), its length, and what became of it."""
    for number, candidate in enumerate(candidates):
        x, y, z = (1000 * v for v in candidate.centre_m)
        stderr(f"  candidate {number} at ({x:.0f}, {y:.0f}, {z:.0f}) mm, {candidate.length_m * 1000:.0f} mm: "
               f"{candidate.outcome}")
