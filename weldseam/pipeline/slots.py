"""Slots: a groove between two parts' sides that are not in line is no butt joint.

The plates of a butt joint (V-groove, single bevel, square butt) lie in line: the surfaces beside
the groove's two edges turn by a few degrees at most (welding distortion). A clamp's post standing
3-8 mm beside a block, or a bar lying against a part, leaves a slot between two faces at any angle
to each other, which a section fits as a groove over a few cross-sections. Along a real groove a
few sections turn too (where another groove meets it, or a plate's edge enters the window), so the
rule reads the whole seam: most of its sections must see the sides in line. Each side is read
across the whole section window (section.half_width_m): over 20 mm a slope is measured within a
few degrees in a noisy scan, over the 12 mm that set the torch axis only within ~10.

A groove's walls also close in: a V's (or bevel's) walls include 30 degrees or more and meet at
its root (or a root gap a few mm wide); only a square butt's walls stand square, over an opening
of joints.gap_max_m (4 mm) at most. A bar lying on the table beside a plate, its top level with
the plate's, leaves a gap whose walls stand square (a plate's edge, the bar's side) all the way
down to the table: seen from above its tops are in line and it fits as a narrow V. Such a gap is
wider than a square butt opens, deeper than the walls of any V across that opening could reach
(depth > opening / (2 tan 15 deg)), and its bottom is the support plane: what two parts form
with the table between them is no joint (`gap_to_table`).
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
# A V's walls include at least this (degrees); a gap whose opening is narrower than such walls
# could be at its depth has walls that do not close in.
MIN_INCLUDED_DEG = 30.0


def in_line_seams(
    seams: list[TracedSeam], surface: FineSurface, reach_m: float, support=None, tolerance_m: float = 0.0
) -> list[TracedSeam]:
    """The seams that are not slots: every seam but a butt joint whose sides, read within reach_m
    beside its edges, turn by more than MAX_SIDE_TURN_DEG at most of its sections (`slot`), or
    that is a gap down to the support plane (`gap_to_table`; support = (point, unit normal) or
    None, tolerance_m how far from it a point is on it)."""
    return [seam for seam in seams
            if not (slot(seam, surface, reach_m) or gap_to_table(seam, surface, support, tolerance_m))]  # fmt: skip


def slot(seam: TracedSeam, surface: FineSurface, reach_m: float) -> bool:
    """Whether a butt joint's sides are out of line: the median of sides_turn_deg over up to
    SIDE_SAMPLES sections along it (in the seam's own frames, its edges half its opening each side
    of it) exceeds MAX_SIDE_TURN_DEG, with at least MIN_MEASURED sections measured."""
    if seam.joint not in BUTT_JOINTS:
        return False
    travel, axes, lateral = section_frames(seam.positions_m, seam.torch_axes, seam.closed)
    picks = seam.samples(SIDE_SAMPLES)
    half = seam.half_opening_m
    turns = []
    for k in picks:
        profile = surface.profile(seam.positions_m[k], travel[k], axes[k], lateral[k])
        turn = sides_turn_deg(profile.u, profile.w, -half, half, reach_m)
        if turn is not None:
            turns.append(turn)
    return len(turns) >= MIN_MEASURED and float(np.median(turns)) > MAX_SIDE_TURN_DEG


def gap_to_table(seam: TracedSeam, surface: FineSurface, support, tolerance_m: float) -> bool:
    """Whether a butt joint is a gap between two parts down to the table. Up to SIDE_SAMPLES
    sections along it are fitted again as its kind; a section is deep where its opening is wider
    than a square butt's (joints.gap_max_m) and the groove deeper than walls including
    MIN_INCLUDED_DEG could reach across it (depth > opening / (2 tan 15 deg)), and reaches the
    table where its bottom (the seam point `depth` along the torch axis) also lies within
    `tolerance_m` of the support plane (point, unit normal; None: no table, no gap to it). A gap:
    at least MIN_MEASURED sections measured, most of them deep, and MIN_MEASURED or more reaching
    the table (a narrow gap hides its bottom from a camera looking in at an angle)."""
    if seam.joint not in BUTT_JOINTS or support is None:
        return False
    centre, normal = support
    travel, axes, lateral = section_frames(seam.positions_m, seam.torch_axes, seam.closed)
    picks = seam.samples(SIDE_SAMPLES)
    fits = surface.fit_many(seam.positions_m[picks], travel[picks], axes[picks], lateral[picks], {seam.joint})
    measured = [f for f in fits if f.kind is not None and f.geometry.depth_m is not None and f.geometry.opening_m]
    if len(measured) < MIN_MEASURED:
        return False
    depth, opening = (np.array([getattr(f.geometry, name) for f in measured]) for name in ("depth_m", "opening_m"))
    walls_reach = opening / (2 * np.tan(np.radians(MIN_INCLUDED_DEG / 2)))
    deep = (opening > surface.params.joints.gap_max_m) & (depth > walls_reach)
    bottoms = np.array([f.point_m for f in measured]) + depth[:, None] * np.array([f.torch_axis for f in measured])
    on_table = np.abs((bottoms - centre) @ normal) <= tolerance_m
    return np.count_nonzero(deep) > len(measured) / 2 and np.count_nonzero(deep & on_table) >= MIN_MEASURED


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
