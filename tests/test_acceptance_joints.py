"""Acceptance for every further joint (lap, single bevel, square butt, outside corner, pipe on
plate, saddle, tack welds, clutter, a shallow curved valley, a lap beside a fillet, a V-groove
beside a square butt), drawn from the broad world: clamps and loose bars, a camera anywhere
in the cone that sees the seam, ripple, stereo shadow.

The criteria of issue 22, each a test per family and seed: the right number of seams; mean
position error <= 0.5 mm; >= 95 % of the seen seam within 2 mm of the path; mean torch-axis
error <= 3 degrees; in a scene with two kinds (a lap and a fillet, a V-groove and a square
butt), each seam named by its own. Known gaps are strict xfails: when a change closes one, its
test fails until the mark is removed, so the list stays the truth about what the planner does.
Seeds 0-4; today 210 of the 220 criteria hold (lap, bevel, outside corner, square butt, tack
welds, pipe on plate and the two-kind scenes mostly; saddle and the shallow valley least; 209 on
machines that put clutter 1 just past 0.5 mm: ON_THE_EDGE), and every seam of the two-kind scenes
gets its own kind.
"""

import numpy as np
import pytest

from weldseam.config import PlanConfig
from weldseam.pipeline.run import plan_paths
from weldseam.synthetic.catalog import NEW_FAMILIES, draw_case
from weldseam.synthetic.metrics import evaluate
from weldseam.types import Scan

SEEDS = (0, 1, 2, 3, 4)
CRITERIA = {
    "count": lambda m: m["seams_found"] == m["seams_expected"],
    "position": lambda m: m["mean_position_error_m"] <= 0.0005,
    "coverage": lambda m: m["coverage"] >= 0.95,
    "axis": lambda m: m["mean_axis_error_deg"] <= 3.0,
}
KNOWN_GAPS: dict[tuple[str, int], set[str]] = {
    ("lap", 0): {"position", "coverage"},
    ("lap", 2): {"coverage"},
    ("square_butt", 2): {"coverage"},
    ("outside_corner", 4): {"position"},
    # On the edge: 3.00 degrees, and 3.09 since the branch's face is carried along the axis of full
    # fits gathered over more of the seam where its last 32 mm hold few (extend.CORNER_FITS).
    ("saddle", 2): {"axis"},
    # Carried on along its flank, the seam comes within 20 mm of a 12 mm piece past a stretch the
    # branch pipe hides, and is joined to it along its curve (join._curves_on: no longer through a
    # corner 8.7 mm off the seam, 1.20 -> 0.31 mm, 7.7 -> 2.0 degrees); 92 % covered.
    ("saddle", 1): {"coverage"},
    # Found since the wide valley pass (20 mm); its 147-degree corner scatters 1.3 mm across.
    ("valley", 4): {"position", "coverage", "axis"},
}
# Criteria on the edge of their limit, which machines of one kind put either side of it: the same
# code and packages (constraints.txt) render the synthetic scans a little differently (a sample
# scan one 1 mm voxel apart), and clutter 1 comes out 0.536 mm off on one machine (Xeon with
# AVX-512 FP16) and under 0.5 on another (the session before, and its CI). Not strict.
ON_THE_EDGE: dict[tuple[str, int], set[str]] = {
    ("clutter", 1): {"position"},
}
# Scenes holding two joint kinds: each seam must come out named by its own.
MIXED_FAMILIES = ("lap_and_fillet", "v_groove_and_square_butt")
_results: dict = {}


def scored(family: str, seed: int) -> dict:
    """Plan and score one broad-world scan (once per session)."""
    if (family, seed) not in _results:
        scene, scan = draw_case(family, seed, broad=True)
        result = plan_paths(
            Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source=family),
            PlanConfig(), allow_empty=True,
        )
        _results[family, seed] = evaluate(result.paths, scan, scene)
    return _results[family, seed]


def marks(family: str, seed: int, criterion: str) -> list:
    """A known gap's strict xfail, an edge case's lenient one, or none."""
    if criterion in KNOWN_GAPS.get((family, seed), ()):
        return [pytest.mark.xfail(strict=True, reason="known gap")]
    if criterion in ON_THE_EDGE.get((family, seed), ()):
        return [pytest.mark.xfail(strict=False, reason="on the edge: either side by machine")]
    return []


CASES = [
    pytest.param(
        family, seed, criterion, id=f"{family}-{seed}-{criterion}",
        marks=marks(family, seed, criterion),
    )
    for family in NEW_FAMILIES for seed in SEEDS for criterion in CRITERIA
]


@pytest.mark.parametrize("family, seed, criterion", CASES)
def test_joint_meets_the_criterion(family, seed, criterion):
    metrics = scored(family, seed)
    # A case with no seam has no error to measure: it fails position, coverage and axis.
    assert CRITERIA[criterion](metrics), metrics


@pytest.mark.parametrize("family, seed", [(family, seed) for family in MIXED_FAMILIES for seed in SEEDS])
def test_a_scene_with_two_joint_kinds_gives_each_seam_its_own(family, seed):
    metrics = scored(family, seed)
    assert metrics["seams_expected"] == 2 and metrics["kinds_matched"] == 2, metrics
