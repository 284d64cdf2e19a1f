"""Slots: a groove between two parts' sides that are not in line is no butt joint.

The plates of a butt joint (V-groove, single bevel, square butt) lie in line: the surfaces beside
the groove's two edges turn by a few degrees at most (welding distortion). A clamp's post standing
3-8 mm beside a block, or a bar lying against a part, leaves a slot between two faces at any angle
to each other, which a section fits as a groove over a few cross-sections. Along a real groove a
few sections turn too (where another groove meets it, or a plate's edge enters the window), so the
rule reads the whole seam: most of its sections must see the sides in line. Each side is read
across the whole section window (section.half_width_m): over 20 mm a slope is measured within a
few degrees in a noisy scan, over the 12 mm that set the torch axis only within ~10.
"""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import FineSurface, section_frames
from weldseam.pipeline.trace import TracedSeam

BUTT_JOINTS = frozenset({JointKind.V_GROOVE, JointKind.BEVEL, JointKind.SQUARE_BUTT})
# The plates beside a butt joint turn by at most this (degrees): distortion bends them a few.
MAX_SIDE_TURN_DEG = 10.0
# The points within this of a groove edge may lie on its wall (a square wall stands at the edge).
EDGE_MARGIN_M = 0.001
# Sections read along a seam (evenly spaced), and the fewest whose sides must be measured.
SIDE_SAMPLES = 15
MIN_MEASURED = 3


def in_line_seams(seams: list[TracedSeam], surface: FineSurface, reach_m: float) -> list[TracedSeam]:
    """The seams that are not slots (`slot`): every seam but a butt joint whose sides, read within
    reach_m beside its edges, turn by more than MAX_SIDE_TURN_DEG at most of its sections."""
    return [seam for seam in seams if not slot(seam, surface, reach_m)]


def slot(seam: TracedSeam, surface: FineSurface, reach_m: float) -> bool:
    """Whether a butt joint's sides are out of line: the median of sides_turn_deg over up to
    SIDE_SAMPLES sections along it (in the seam's own frames, its edges half its opening each side
    of it) exceeds MAX_SIDE_TURN_DEG, with at least MIN_MEASURED sections measured."""
    if seam.joint not in BUTT_JOINTS:
        return False
    travel, axes, lateral = section_frames(seam.positions_m, seam.torch_axes, seam.closed)
    count = len(seam.positions_m)
    picks = np.unique(np.linspace(0, count - 1, min(SIDE_SAMPLES, count)).round().astype(int))
    half = seam.half_opening_m
    turns = []
    for k in picks:
        profile = surface.profile(seam.positions_m[k], travel[k], axes[k], lateral[k])
        turn = sides_turn_deg(profile.u, profile.w, -half, half, reach_m)
        if turn is not None:
            turns.append(turn)
    return len(turns) >= MIN_MEASURED and float(np.median(turns)) > MAX_SIDE_TURN_DEG


def sides_turn_deg(x: np.ndarray, h: np.ndarray, left_edge: float, right_edge: float, reach_m: float) -> float | None:
    """The angle (degrees) between the directions of the profile's points (x across, h height, m)
    from EDGE_MARGIN_M to reach_m beside each edge (left of left_edge, right of right_edge), each
    the median slope s of its pairs of points a quarter of reach_m or more apart (a few stray
    points do not tilt it): |atan(s_left) - atan(s_right)|. None when a side holds fewer than 6
    points or spans less than a quarter of reach_m."""
    left = (x >= left_edge - reach_m) & (x <= left_edge - EDGE_MARGIN_M)
    right = (x >= right_edge + EDGE_MARGIN_M) & (x <= right_edge + reach_m)
    if any(np.count_nonzero(side) < 6 or np.ptp(x[side]) < reach_m / 4 for side in (left, right)):
        return None
    slopes = [median_slope(x[side], h[side], reach_m / 4) for side in (left, right)]
    return float(abs(np.degrees(np.arctan(slopes[0]) - np.arctan(slopes[1]))))


def median_slope(x: np.ndarray, h: np.ndarray, min_run_m: float) -> float:
    """The median of dh / dx over the pairs of points min_run_m or more apart in x (Theil-Sen)."""
    dx, dh = x[None, :] - x[:, None], h[None, :] - h[:, None]
    apart = dx >= min_run_m
    return float(np.median(dh[apart] / dx[apart]))
