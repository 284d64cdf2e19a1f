"""Reports: see a planned path on its scan, as an offline HTML page and a PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from weldseam.io.atomic import atomic_write
from weldseam.report.figure import DEFAULT_POINT_BUDGET, make_drawing
from weldseam.types import WeldPath


def write_report(
    points_m: np.ndarray,
    paths: list[WeldPath],
    record: dict,
    html_path: str | Path | None,
    png_path: str | Path | None = None,
    *,
    scan_name: str = "",
    values: np.ndarray | None = None,
    value_name: str = "descriptor",
    candidates_m: np.ndarray | None = None,
    point_budget: int = DEFAULT_POINT_BUDGET,
) -> None:
    """Write the HTML report and/or the PNG (each atomically).

    points_m: (N, 3) the scan in the base frame; values: (N,) per-point colour values (else height);
    record: the path JSON document (params, timings_s, warnings, seams, input) for the panel.
    """
    from weldseam.report.html import report_html
    from weldseam.report.png import report_png

    drawing = make_drawing(
        points_m, paths, values=values, value_name=value_name, candidates_m=candidates_m, point_budget=point_budget
    )
    title = f"weldseam: {scan_name}" if scan_name else "weldseam"
    if html_path is not None:
        atomic_write(html_path, report_html(drawing, record, title).encode("utf-8"))
    if png_path is not None:
        atomic_write(png_path, report_png(drawing, record, title))
