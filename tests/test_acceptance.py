"""Acceptance on noisy D415-like synthetic scans of every workpiece family.

The criteria of the plan issue, each a test per family and seed: the right number of
seams; mean position error <= 0.5 mm; >= 95 % of the seen seam length within 2 mm of
the path; mean torch-axis error <= 3 degrees. Known gaps are strict xfails: when a change
closes one, its test fails until the mark is removed, so the list stays true.
"""

import numpy as np
import pytest

from weldseam.config import PlanConfig
from weldseam.pipeline.run import plan_paths
from weldseam.synthetic.metrics import evaluate
from weldseam.synthetic.scenes import FAMILIES, make_scan
from weldseam.types import Scan

SEEDS = (0, 1)
KNOWN_GAPS: dict[tuple[str, int], set[str]] = {}
CASES = [(family, seed) for family in FAMILIES for seed in SEEDS]
_results: dict = {}


def scored(family: str, seed: int) -> dict:
    """Plan and score one rendered scan (once per session)."""
    if (family, seed) not in _results:
        rng = np.random.default_rng(seed)
        scene = FAMILIES[family](rng)
        scan = make_scan(scene, rng)
        result = plan_paths(
            Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source=family),
            PlanConfig(), allow_empty=True,
        )
        _results[family, seed] = evaluate(result.paths, scan, scene)
    return _results[family, seed]


def cases(criterion: str, *, with_seams: bool = True):
    return [
        pytest.param(
            family, seed, id=f"{family}-{seed}",
            marks=[pytest.mark.xfail(strict=True, reason="known gap")] if criterion in KNOWN_GAPS.get((family, seed), ()) else [],
        )
        for family, seed in CASES
        if not with_seams or family != "plain_plate"
    ]


@pytest.mark.parametrize("family, seed", cases("count", with_seams=False))
def test_seam_count(family, seed):
    metrics = scored(family, seed)
    assert metrics["seams_found"] == metrics["seams_expected"]


@pytest.mark.parametrize("family, seed", cases("position"))
def test_mean_position_error_within_half_a_millimetre(family, seed):
    assert scored(family, seed)["mean_position_error_m"] <= 0.0005


@pytest.mark.parametrize("family, seed", cases("coverage"))
def test_seam_length_covered(family, seed):
    assert scored(family, seed)["coverage"] >= 0.95


@pytest.mark.parametrize("family, seed", cases("axis"))
def test_mean_torch_axis_error_within_three_degrees(family, seed):
    assert scored(family, seed)["mean_axis_error_deg"] <= 3.0
