"""`weldseam report`: see a path on its scan, as an offline HTML page and a PNG."""

from __future__ import annotations

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
    reported,
    stderr,
)

EPILOG = (
    "Example:\n\n"
    "  weldseam report samples/v_butt.ply path.json -o report.html\n\n"
    "  weldseam report scan.png path.json --intrinsics d415.json --camera-pose pose.json -o r.html --png r.png\n\n"
    "  weldseam report left.png top.png right.png path.json --hand-eye H.json -o r.html   (several frames)\n\n"
    "  weldseam plan scan.ply -o path.json --report report.html   (the same, while planning)\n\n"
    "The scan is placed as plan places it, with the same options; without any, as the path JSON records it "
    "for that scan. A scan whose sha256 is not the one the path was planned from, or that ends up in another "
    "frame than the path, is drawn with a warning. The page is one file with everything embedded (it opens "
    "offline). The seam candidates are found again with the path file's own parameters.\n\n"
    f"{PLACEMENT_HELP}\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)


def report(
    scans: Scans = None,
    path_file: Annotated[str, typer.Argument(help="The path JSON written by weldseam plan.", show_default=False)] = ...,
    output: Annotated[Optional[str], typer.Option("--output", "-o", help="HTML report to write (.html).")] = None,
    png: Annotated[Optional[str], typer.Option(help="Also write a static PNG of the same view (.png).")] = None,
    color: Annotated[str, typer.Option(help="Colour the scan by height or descriptor.")] = "height",
    point_budget: Annotated[int, typer.Option(help="Most scan points drawn (keeps big scans responsive).")] = 60000,
    frames: FramesOption = None,
    intrinsics: IntrinsicsOption = None,
    camera_pose: CameraPoseOption = None,
    flange_pose: FlangePoseOption = None,
    joints: JointsOption = None,
    hand_eye: HandEyeOption = None,
    robot: RobotOption = None,
    cloud_frame: CloudFrameOption = None,
    camera_origin: CameraOriginOption = None,
    units: UnitsOption = None,
) -> None:
    """Write an HTML report (and a PNG) of a planned path over its scan."""
    with reported():
        import json

        from weldseam.config import effective_config
        from weldseam.errors import InputError
        from weldseam.io.atomic import check_writable
        from weldseam.io.files import read_input
        from weldseam.io.paths import read_paths
        from weldseam.io.placement import PlacementOptions, place_scans, read_recorded
        from weldseam.report import write_report

        if output is None and png is None:
            raise InputError("nothing to write: give -o report.html and/or --png report.png")
        for name, target, suffix in (("-o", output, ".html"), ("--png", png, ".png")):
            if target is not None and not target.lower().endswith(suffix):
                raise InputError(f"{name} {target}: the report writes {suffix} files only")
            if target is not None:
                check_writable(target)
        if color not in ("height", "descriptor"):
            raise InputError(f"--color must be height or descriptor, got {color!r}")
        if point_budget < 100:
            raise InputError(f"--point-budget must be at least 100, got {point_budget}")
        if not path_file.lower().endswith(".json"):
            raise InputError(f"{path_file}: the report needs the path JSON (it holds the run's record)")
        paths = read_paths(path_file)
        record = json.loads(read_input(path_file, "a path file"))
        placed = place_scans(
            PlacementOptions(tuple(scans or ()), frames, intrinsics, camera_pose, flange_pose, joints, hand_eye,
                             robot, cloud_frame, camera_origin, units),
            read_recorded(path_file),
        )
        for message in placed.messages:
            stderr(message)
        warnings = [*placed.warnings, *_mismatches(placed, record, path_file)]
        for warning in warnings:
            stderr(f"Warning: {warning}")
        working, descriptor, candidates = _candidates(placed, effective_config(path_file, {}))
        points, values = (working, descriptor) if color == "descriptor" else (placed.merged().points_m, None)
        write_report(
            points,
            paths,
            {**record, "warnings": [*record.get("warnings", []), *warnings]},
            output,
            png,
            scan_name=placed.source,
            values=values,
            candidates_m=candidates,
            point_budget=point_budget,
        )
        stderr(f"report of {len(paths)} seam(s) -> {', '.join(name for name in (output, png) if name)}")


def _candidates(placed, config):
    """(working cloud (M, 3), its descriptor (M,), the candidates' points (C, 3)) of the placed
    scans: the pipeline's steps up to `segment` only (several frames merged first, as plan does)."""
    from weldseam.pipeline.frames import merged_scan
    from weldseam.pipeline.run import run_steps

    scan = placed.frames[0] if len(placed.frames) == 1 else merged_scan(placed.frames, config, source=placed.source)[0]
    state = run_steps(scan, config, last="segment")
    return state.working, state.descriptor, state.candidate_points()


def _mismatches(placed, record: dict, path_file: str) -> list[str]:
    """Warnings when the scans are not the ones the path was planned from, or not in its frame."""
    inputs = record.get("input") if isinstance(record.get("input"), dict) else {}
    recorded = [frame.get("sha256") for frame in inputs.get("frames", []) if isinstance(frame, dict)]
    recorded = recorded or [inputs.get("sha256")]
    warnings = [
        f"{scan.source}: its sha256 is not the one {path_file} was planned from: the path may belong to another scan"
        for k, scan in enumerate(placed.frames)
        if k >= len(recorded) or scan.sha256 != recorded[k]
    ]
    path_frame = record.get("frame", "base")
    if placed.frame != path_frame:
        warnings.append(
            f"the scan is in the {placed.frame} frame but {path_file} is in the {path_frame} frame: they are drawn "
            "apart; give the scan's placement (--camera-pose, --flange-pose or --joints with --hand-eye)"
        )
    return warnings
