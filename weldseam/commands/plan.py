"""`weldseam plan`: one scan in, the ordered torch path out."""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Optional

import typer

from weldseam.commands.common import EXIT_TABLE, command_overrides, reported, stderr
from weldseam.errors import InputError

EPILOG = (
    "Example:\n\n"
    "  weldseam plan samples/v_butt.ply --camera-origin 0.02,-0.1,0.45 -o path.json\n\n"
    "  weldseam plan depth.png --intrinsics d415.json --camera-pose pose.json -o - --format csv\n\n"
    "  weldseam plan depth.png --intrinsics d415.json --joints 0,-1.57,1.57,-1.57,-1.57,0 --hand-eye H.json\n\n"
    "  weldseam plan left.png top.png right.png --intrinsics d415.json --hand-eye H.json -o path.json\n\n"
    "  (several frames of one workpiece: left.pose.json, top.pose.json, right.pose.json beside them)\n\n"
    "  weldseam plan --frames frames.json -o path.json\n\n"
    "Pose files (--camera-pose, NAME.pose.json, frames of --frames) hold exactly one of "
    '{"T_base_camera": 4x4 row-major, camera -> base, m}, {"flange_pose": [x,y,z,rx,ry,rz]} (UR pose '
    'vector of tool0, m and rad) or {"joints_rad": [q1..q6]} (UR5). A hand-eye file is '
    '{"setup": "eye-in-hand", "T_flange_camera": 4x4} or {"setup": "eye-to-hand", "T_base_camera": 4x4}. '
    'A frames manifest is {"hand_eye": "H.json", "frames": [{"scan": "a.png", "intrinsics": "d415.json", '
    '"joints_rad": [...]}, {"scan": "b.png", "pose": "b.pose.json"}]} (paths relative to it).\n\n'
    f"Exit codes:\n\n{EXIT_TABLE}"
)


def plan(
    scans: Annotated[
        Optional[list[str]],
        typer.Argument(
            help="Scan: .ply .pcd .xyz .txt .npy, a 16-bit depth .png, or - (PLY on stdin). Several scans are "
            "frames of one workpiece, each with its pose in NAME.pose.json beside it.",
            show_default=False,
        ),
    ] = None,
    frames: Annotated[
        Optional[str],
        typer.Option(help="Frames manifest JSON: several scans of one workpiece with their poses (see below)."),
    ] = None,
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
    intrinsics: Annotated[Optional[str], typer.Option(help="Intrinsics JSON for a depth image.")] = None,
    camera_pose: Annotated[
        Optional[str], typer.Option(help='Pose file: {"T_base_camera": 4x4 row-major}, or a robot state (below).')
    ] = None,
    flange_pose: Annotated[
        Optional[str],
        typer.Option(help="Flange (tool0) pose at capture x,y,z,rx,ry,rz (m, rotation vector); needs --hand-eye."),
    ] = None,
    joints: Annotated[
        Optional[str], typer.Option(help="UR5 joint angles at capture q1,...,q6 (rad); needs --hand-eye.")
    ] = None,
    hand_eye: Annotated[
        Optional[str], typer.Option(help="Hand-eye calibration JSON (eye-in-hand or eye-to-hand).")
    ] = None,
    cloud_frame: Annotated[str, typer.Option(help="Frame of a cloud file: base or camera.")] = "base",
    camera_origin: Annotated[
        Optional[str],
        typer.Option(help="Camera centre x,y,z in the base frame (m), to orient normals."),
    ] = None,
    units: Annotated[str, typer.Option(help="Units of a cloud file: m or mm.")] = "m",
    crop: Annotated[
        Optional[str],
        typer.Option(help="Keep only points in the box x0,y0,z0,x1,y1,z1 (base frame, m)."),
    ] = None,
    threshold: Annotated[Optional[float], typer.Option(help="Descriptor threshold (default: automatic).")] = None,
    spacing_mm: Annotated[
        Optional[float],
        typer.Option(help="Pose spacing along the seam, mm (default 2)."),
    ] = None,
    config_file: Annotated[
        Optional[str],
        typer.Option("--config", help="TOML config file (see `weldseam config show`), or a path JSON to rerun."),
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
        import numpy as np

        from weldseam.config import effective_config
        from weldseam.io.clouds import write_ply
        from weldseam.io.hand_eye import camera_pose as camera_pose_of
        from weldseam.io.hand_eye import read_hand_eye
        from weldseam.io.paths import write_paths
        from weldseam.io.poses import parse_vector
        from weldseam.io.scan import load_scan
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
        config = effective_config(config_file, overrides)
        origin = parse_vector(camera_origin, 3, "--camera-origin") if camera_origin else None
        started = time.perf_counter()
        specs, hand_eye_path = _frame_specs(scans or [], frames, camera_pose, flange_pose, joints, origin)
        hand_eye_path = hand_eye if hand_eye is not None else hand_eye_path
        calibration = read_hand_eye(hand_eye_path) if hand_eye_path is not None else None
        notes: list[str] = []
        loaded_frames = []
        for spec in specs:
            fixed_camera = calibration is not None and calibration.setup == "eye-to-hand"
            if len(specs) > 1 and spec.pose is None and not fixed_camera:
                raise InputError(f"{spec.scan}: no pose: give {_sidecar_name(spec.scan)} or use a --frames manifest")
            pose, pose_notes = camera_pose_of(spec.pose, calibration)
            frame, frame_notes = load_scan(
                spec.scan, intrinsics_path=spec.intrinsics if spec.intrinsics is not None else intrinsics,
                T_base_camera=pose, cloud_frame=cloud_frame, camera_origin_m=origin, units=units,
            )
            loaded_frames.append(frame)
            notes += pose_notes + frame_notes
        loaded = loaded_frames[0]
        if len(loaded_frames) > 1:  # the report shows every frame's points
            loaded = replace(loaded, points_m=np.vstack([frame.points_m for frame in loaded_frames]))
        if report is not None and not report.lower().endswith((".html", ".png")):
            raise InputError(f"--report {report}: the report is a .html or a .png file")
        stages: dict[str, tuple] = {}
        counter = iter(range(100))
        if dump_stages is not None:
            dump_stages.mkdir(parents=True, exist_ok=True)

        def dump(stage: str, points, values) -> None:
            if report is not None:
                stages.setdefault(stage, (points, values))
            if dump_stages is not None:
                write_ply(dump_stages / f"{next(counter):02d}_{stage}.ply", points, values=values)

        with _progress(enabled=not quiet) as on_stage, _candidates_shown(verbose and not quiet):
            if len(loaded_frames) > 1:
                source = frames if frames is not None else ",".join(spec.scan for spec in specs)
                result = plan_frames(
                    loaded_frames, config, source=source, dump=dump, on_stage=on_stage, allow_empty=allow_empty
                )
            else:
                result = plan_paths(loaded, config, dump=dump, on_stage=on_stage, allow_empty=allow_empty)
        write_paths(
            result,
            output,
            fmt=None if config.output.format == "auto" else config.output.format,
            rotation=config.output.rotation,
        )
        if report is not None:
            _write_report(report, loaded, result, stages)
        if not quiet:
            for message in [*notes, *result.warnings]:
                stderr(f"Warning: {message}")
            _report(result, output, time.perf_counter() - started, verbose)


def _frame_specs(scans: list[str], manifest, camera_pose, flange_pose, joints, origin):
    """The frames to plan and the manifest's hand-eye file: one frame from the options, several
    from the positional scans (poses in NAME.pose.json sidecars) or from a --frames manifest.
    Options that conflict are one InputError naming them."""
    from weldseam.batch import sidecars
    from weldseam.io.poses import FramePose, parse_vector, pose_vector_matrix, read_pose_file
    from weldseam.io.scan import FrameSpec, read_frames_manifest

    given = [name for name, value in (("--camera-pose", camera_pose), ("--flange-pose", flange_pose),
                                      ("--joints", joints)) if value is not None]
    if len(given) > 1:
        raise InputError(f"{' and '.join(given)}: give one pose of the camera, not several")
    several = manifest is not None or len(scans) > 1
    if several and (given or origin is not None):
        option = given[0] if given else "--camera-origin"
        raise InputError(f"{option} applies to a single scan; with several frames each has its own pose")
    if manifest is not None:
        if scans:
            raise InputError(f"--frames {manifest}: give the scans in the manifest or on the command line, not both")
        return read_frames_manifest(manifest)
    if not scans:
        raise InputError("no scan given: weldseam plan SCAN [SCAN ...] or weldseam plan --frames FILE.json")
    if len(scans) > 1:
        specs, seen = [], {}
        for scan in scans:
            if scan == "-":
                raise InputError("- (stdin) can only be a single scan")
            intrinsics, pose = sidecars(Path(scan))
            if pose is not None and pose in seen:
                raise InputError(
                    f"{scan} and {seen[pose]} share the pose file {pose}: give each frame its own {_sidecar_name(scan)}"
                )
            if pose is not None:
                seen[pose] = scan
            specs.append(FrameSpec(scan, None if intrinsics is None else str(intrinsics),
                                   None if pose is None else read_pose_file(pose)))
        return specs, None
    if flange_pose is not None:
        pose = FramePose("--flange-pose", flange_pose=pose_vector_matrix(parse_vector(flange_pose, 6, "--flange-pose"),
                                                                          "--flange-pose"))
    elif joints is not None:
        pose = FramePose("--joints", joints_rad=parse_vector(joints, 6, "--joints"))
    else:
        pose = read_pose_file(camera_pose) if camera_pose is not None else None
    return [FrameSpec(scans[0], None, pose)], None


def _sidecar_name(scan: str) -> str:
    path = Path(scan)
    return str(path.with_name(f"{path.name[: -len(path.suffix)] if path.suffix else path.name}.pose.json"))


def _write_report(target: str, scan, result, stages: dict) -> None:
    import json

    from weldseam.io.paths import format_path_json
    from weldseam.report import write_report

    html, png = (target, None) if target.lower().endswith(".html") else (None, target)
    candidates = stages.get("segment", (None, None))[0]
    record = json.loads(format_path_json(result))
    write_report(scan.points_m, list(result.paths), record, html, png, scan_name=scan.source, candidates_m=candidates)


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
