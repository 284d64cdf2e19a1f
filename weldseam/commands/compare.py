"""`weldseam compare`: is a path file within tolerance of another (a golden file)?"""

from __future__ import annotations

import json
import sys
from typing import Annotated

import typer

from weldseam.commands.common import reported, stderr

EPILOG = (
    "Example:\n\n"
    "  weldseam compare path.json samples/golden/v_butt.json --tol-mm 0.1 --tol-deg 0.5\n\n"
    "  weldseam compare path.csv golden.json --json > report.json\n\n"
    "Seams are matched by geometry (order, ids and direction do not matter). Position deviation:\n"
    "distance from each pose to the other seam's polyline, both ways; axis deviation: angle to\n"
    "the torch axis of the nearest pose of the other seam.\n\n"
    "Exit codes:\n\n"
    "0: every seam matched and within tolerance\n\n"
    "1: a deviation beyond tolerance, or a seam without a partner\n\n"
    "2: a file is missing or unreadable"
)


def compare(
    first: Annotated[str, typer.Argument(help="Path file A (.json or .csv).")],
    second: Annotated[str, typer.Argument(help="Path file B, e.g. the golden file.")],
    tol_mm: Annotated[float, typer.Option("--tol-mm", help="Largest allowed position deviation, mm.")] = 0.5,
    tol_deg: Annotated[float, typer.Option("--tol-deg", help="Largest allowed torch-axis deviation, degrees.")] = 2.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON on stdout.")] = False,
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="No summary line on stderr; the exit code says it.")
    ] = False,
) -> None:
    """Compare two path files seam by seam; exit 0 only if they agree within tolerance."""
    with reported():
        from weldseam.compare import compare_paths
        from weldseam.errors import InputError
        from weldseam.io.paths import read_paths

        if tol_mm < 0 or tol_deg < 0:
            raise InputError("--tol-mm and --tol-deg must not be negative")
        tolerance_m = tol_mm / 1000
        # Seams farther apart than twice the tolerance (at least 10 mm) are different seams.
        comparison = compare_paths(read_paths(first), read_paths(second), match_limit_m=max(0.01, 2 * tolerance_m))
        if as_json:
            print(json.dumps(comparison.to_dict(tolerance_m, tol_deg), indent=2))
        else:
            _print_table(comparison, tolerance_m, tol_deg)
        if not quiet:
            stderr(_summary(comparison, tolerance_m, tol_deg, first, second))
        if not comparison.within(tolerance_m, tol_deg):
            raise typer.Exit(1)


def _summary(comparison, tolerance_m: float, tolerance_deg: float, first: str, second: str) -> str:
    verdict = "within" if comparison.within(tolerance_m, tolerance_deg) else "NOT within"
    return (
        f"{first}: {comparison.count_a} seam(s), {second}: {comparison.count_b} seam(s); "
        f"{verdict} {tolerance_m * 1000:g} mm / {tolerance_deg:g} deg"
    )


def _print_table(comparison, tolerance_m: float, tolerance_deg: float) -> None:
    """Rich table on a terminal, plain aligned text otherwise (both on stdout)."""
    header = ("seam A", "seam B", "max mm", "mean mm", "axis deg", "length diff mm", "result")
    rows = [
        (
            "-" if seam.seam_a is None else str(seam.seam_a),
            "-" if seam.seam_b is None else str(seam.seam_b),
            *(
                ("-", "-", "-", "-")
                if not seam.matched
                else (
                    f"{seam.max_deviation_m * 1000:.3f}",
                    f"{seam.mean_deviation_m * 1000:.3f}",
                    f"{seam.max_axis_deviation_deg:.2f}",
                    f"{seam.length_difference_m * 1000:+.2f}",
                )
            ),
            "ok" if seam.within(tolerance_m, tolerance_deg) else ("unmatched" if not seam.matched else "OUTSIDE"),
        )
        for seam in comparison.seams
    ]
    if sys.stdout.isatty():
        from rich.console import Console
        from rich.table import Table

        table = Table(*header)
        for row in rows:
            table.add_row(*row)
        Console().print(table)
    else:
        widths = [max(len(header[k]), *(len(row[k]) for row in rows)) for k in range(len(header))] if rows else None
        if widths:
            print("  ".join(name.rjust(width) for name, width in zip(header, widths)))
            for row in rows:
                print("  ".join(cell.rjust(width) for cell, width in zip(row, widths)))
