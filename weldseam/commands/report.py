"""`weldseam report`: see a path on its scan, as an offline HTML page and a PNG."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from weldseam.commands.common import EXIT_TABLE, reported, stderr

EPILOG = (
    "Example:\n\n"
    "  weldseam report samples/v_butt.ply path.json --camera-pose samples/v_butt.pose.json -o report.html\n\n"
    "  weldseam report scan.png path.json --intrinsics d415.json --camera-pose pose.json -o r.html --png r.png\n\n"
    "  weldseam plan scan.ply -o path.json --report report.html   (the same, while planning)\n\n"
    "The page is one file with everything embedded (it opens offline). The seam candidates are\n"
    "found again with the path file's own parameters.\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)


def report(
    scan: Annotated[str, typer.Argument(help="The scan the path was planned from (same forms as plan).")],
    path_file: Annotated[str, typer.Argument(help="The path JSON written by weldseam plan.")],
    output: Annotated[Optional[str], typer.Option("--output", "-o", help="HTML report to write.")] = None,
    png: Annotated[Optional[str], typer.Option(help="Also write a static PNG of the same view.")] = None,
    color: Annotated[str, typer.Option(help="Colour the scan by height or descriptor.")] = "height",
    point_budget: Annotated[int, typer.Option(help="Most scan points drawn (keeps big scans responsive).")] = 60000,
    intrinsics: Annotated[Optional[str], typer.Option(help="Intrinsics JSON for a depth image.")] = None,
    camera_pose: Annotated[Optional[str], typer.Option(help='JSON {"T_base_camera": 4x4 row-major}.')] = None,
    cloud_frame: Annotated[str, typer.Option(help="Frame of a cloud file: base or camera.")] = "base",
    units: Annotated[str, typer.Option(help="Units of a cloud file: m or mm.")] = "m",
) -> None:
    """Write an HTML report (and a PNG) of a planned path over its scan."""
    with reported():
        import json

        from weldseam.config import effective_config
        from weldseam.errors import InputError
        from weldseam.io.files import read_input
        from weldseam.io.paths import read_paths
        from weldseam.io.placement import PlacementOptions, place_scans
        from weldseam.report import write_report
        from weldseam.report.overlay import scan_overlay

        if output is None and png is None:
            raise InputError("nothing to write: give -o report.html and/or --png report.png")
        if color not in ("height", "descriptor"):
            raise InputError(f"--color must be height or descriptor, got {color!r}")
        if point_budget < 100:
            raise InputError(f"--point-budget must be at least 100, got {point_budget}")
        paths = read_paths(path_file)
        if not path_file.lower().endswith(".json"):
            raise InputError(f"{path_file}: the report needs the path JSON (it holds the run's record)")
        record = json.loads(read_input(path_file, "a path file"))
        loaded = place_scans(PlacementOptions(
            (scan,), intrinsics=intrinsics, camera_pose=camera_pose, cloud_frame=cloud_frame, units=units
        )).frames[0]
        overlay = scan_overlay(loaded, effective_config(path_file, {}))
        points, values = (overlay.working_m, overlay.descriptor) if color == "descriptor" else (loaded.points_m, None)
        write_report(
            points,
            paths,
            record,
            output,
            png,
            scan_name=scan,
            values=values,
            candidates_m=overlay.candidates_m,
            point_budget=point_budget,
        )
        stderr(f"report of {len(paths)} seam(s) -> {', '.join(name for name in (output, png) if name)}")
