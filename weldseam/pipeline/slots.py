"""Slots: a groove between two parts' sides that are not in line is no butt joint.

The plates of a butt joint (V-groove, single bevel, square butt) lie in line: the surfaces beside
the groove's two edges turn by a few degrees at most (welding distortion), and meet at the seam
within a mm or two of each other (high-low misalignment; the worst of the project's own grooves, in
1 mm of noise, reads 1 mm). A clamp's post standing 3-8 mm beside a block, or a bar lying against a
part, leaves a slot between two faces at any angle to each other, which a section fits as a groove
over a few cross-sections; a clamp's block standing beside a part, its top 3-5 mm below the part's,
leaves a step across the slot, whatever the angle of its top. Along a real groove a few sections
turn too (where another groove meets it, or a plate's edge enters the window), so the rule reads
the whole seam: most of its sections must see the sides in line. Each side is read across the
whole section window (section.half_width_m): over 20 mm a slope is measured within a few degrees in
a noisy scan, over the 12 mm that set the torch axis only within ~10.

A groove's walls also close in: a V's (or bevel's) walls include 30 degrees or more and meet at
its root (or a root gap a few mm wide); only a square butt's walls stand square, over an opening
of joints.gap_max_m (4 mm) at most. A bar lying on the table beside a plate, its top level with
the plate's, leaves a gap whose walls stand square (a plate's edge, the bar's side) all the way
down to the table: seen from above its tops are in line and it fits as a narrow V. Such a gap is
wider than a square butt opens, its walls drawing in less than those of any V would over its
depth (by less than depth x tan 15 deg each, from the opening down to the table seen at its
floor: a plate's edge and a bar 10-15 mm apart show the table across most of the gap), and its
bottom is the support plane: what two parts form with the table between them is no joint
(`gap_to_table`).
"""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import FineSurface, SectionFit, section_frame, section_frames
from weldseam.pipeline.segment import noise_floor
from weldseam.pipeline.trace import TracedSeam

BUTT_JOINTS = frozenset({JointKind.V_GROOVE, JointKind.BEVEL, JointKind.SQUARE_BUTT})
# The plates beside a butt joint turn by at most this (degrees): distortion bends them a few.
MAX_SIDE_TURN_DEG = 10.0
# ... and lie at most this far apart at the seam (m), each side's line extended to it.
MAX_SIDE_STEP_M = 0.002
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
    beside its edges, are out of line (turned or stepped) at most of its sections (`slot`), or
    that is a gap down to the support plane (`gap_to_table`; support = (point, unit normal) or
    None, tolerance_m how far from it a point is on it)."""
    return [seam for seam in seams
            if not (slot(seam, surface, reach_m) or gap_to_table(seam, surface, support, tolerance_m))]  # fmt: skip


def slot(seam: TracedSeam, surface: FineSurface, reach_m: float) -> bool:
    """Whether a butt joint's sides are out of line: over up to SIDE_SAMPLES sections along it (in
    the seam's own frames, its edges half its opening each side of it), the turn and the step
    between its sides (sides_apart) are out_of_line, with at least MIN_MEASURED sections measured."""
    if seam.joint not in BUTT_JOINTS:
        return False
    travel, axes, lateral = section_frames(seam.positions_m, seam.torch_axes, seam.closed)
    picks = seam.samples(SIDE_SAMPLES)
    half = seam.half_opening_m
    apart = []
    for k in picks:
        profile = surface.profile(seam.positions_m[k], travel[k], axes[k], lateral[k])
        sides = sides_apart(profile.u, profile.w, -half, half, reach_m)
        if sides is not None:
            apart.append(sides)
    return len(apart) >= MIN_MEASURED and out_of_line(np.array(apart))


def out_of_line(apart: np.ndarray) -> bool:
    """Whether sections' (turn (degrees), step (m)) between a groove's sides (n, 2) put them out of
    line: the median turn over MAX_SIDE_TURN_DEG or the median step over MAX_SIDE_STEP_M, by more
    than the median's standard error, 1.2533 x 1.4826 x MAD / sqrt(n) (segment.noise_floor). A
    groove wider than half the section window leaves 14 mm of side beside it or less, and its steps
    scatter over millimetres (a real bar's 24-37 mm groove: 0-8 mm, median 2.1 mm +- 0.6); a
    clamp's slot steps alike."""
    middle = np.median(apart, axis=0)
    error = np.array([noise_floor(column, 1.2533) for column in apart.T]) / np.sqrt(len(apart))
    turn_deg, step_m = middle - error
    return bool(turn_deg > MAX_SIDE_TURN_DEG or step_m > MAX_SIDE_STEP_M)


def gap_to_table(seam: TracedSeam, surface: FineSurface, support, tolerance_m: float) -> bool:
    """Whether a butt joint is a gap between two parts down to the table. Up to SIDE_SAMPLES
    sections along it are fitted again as its kind; a section is apart where its opening is wider
    than a square butt's (joints.gap_max_m) and its walls do not close in as a groove's do: from
    the opening down to its floor (the stretch across which the table is seen in it, _floor_m; 0
    where none is) they draw in by less than walls including MIN_INCLUDED_DEG would over its depth,
    (opening - floor) / 2 < depth tan 15 deg. It reaches the table where its bottom (the seam point
    `depth` along the torch axis) lies within `tolerance_m` of the support plane (point, unit
    normal; None: no table, no gap to it). A gap: at least MIN_MEASURED sections measured, most of
    them apart, and MIN_MEASURED or more reaching the table (a narrow gap hides its bottom from a
    camera looking in at an angle)."""
    if seam.joint not in BUTT_JOINTS or support is None:
        return False
    centre, normal = support
    travel, axes, lateral = section_frames(seam.positions_m, seam.torch_axes, seam.closed)
    picks = seam.samples(SIDE_SAMPLES)
    fits = surface.fit_many(seam.positions_m[picks], travel[picks], axes[picks], lateral[picks], {seam.joint})
    measured = [(k, f) for k, f in zip(picks, fits)
                if f.kind is not None and f.geometry.depth_m is not None and f.geometry.opening_m]  # fmt: skip
    if len(measured) < MIN_MEASURED:
        return False
    depth, opening = (np.array([getattr(f.geometry, name) for _, f in measured]) for name in ("depth_m", "opening_m"))
    floor = np.array([_floor_m(surface, f, travel[k], support, tolerance_m) for k, f in measured])
    draw_in = depth * np.tan(np.radians(MIN_INCLUDED_DEG / 2))
    apart = (opening > surface.params.joints.gap_max_m) & ((opening - floor) / 2 < draw_in)
    bottoms = np.array([f.point_m + d * f.torch_axis for (_, f), d in zip(measured, depth)])
    on_table = np.abs((bottoms - centre) @ normal) <= tolerance_m
    return np.count_nonzero(apart) > len(measured) / 2 and np.count_nonzero(apart & on_table) >= MIN_MEASURED


def _floor_m(surface: FineSurface, fit: SectionFit, travel: np.ndarray, support, tolerance_m: float) -> float:
    """How far across (m) the points of a groove's section between its edges (half its opening
    either side of its seam point) that lie within tolerance_m / 2 of the support plane spread: the
    floor the table makes in a gap between two parts (a V's root gap, with its walls' feet)."""
    centre, normal = support
    axis, lateral = section_frame(travel, fit.torch_axis)
    profile = surface.profile(fit.point_m, travel, axis, lateral)
    points = fit.point_m + np.outer(profile.u, lateral) - np.outer(profile.w, axis)
    on_table = (np.abs((points - centre) @ normal) <= tolerance_m / 2) & (np.abs(profile.u) <= fit.half_opening_m)
    return float(np.ptp(profile.u[on_table])) if on_table.any() else 0.0


def sides_apart(
    x: np.ndarray, h: np.ndarray, left_edge: float, right_edge: float, reach_m: float
) -> tuple[float, float] | None:
    """(turn (degrees), step (m)) between the lines of the profile's points (x across, h height,
    m) from EDGE_MARGIN_M to reach_m beside each edge (left of left_edge, right of right_edge):
    each line's slope s the median slope of its pairs of points a quarter of reach_m or more apart
    (a few stray points do not tilt it), its height at x = 0 the median of h - s x; the turn is
    |atan(s_left) - atan(s_right)|, the step the difference of the heights. None when a side holds
    fewer than 6 points or spans less than a quarter of reach_m."""
    left = (x >= left_edge - reach_m) & (x <= left_edge - EDGE_MARGIN_M)
    right = (x >= right_edge + EDGE_MARGIN_M) & (x <= right_edge + reach_m)
    if any(np.count_nonzero(side) < 6 or np.ptp(x[side]) < reach_m / 4 for side in (left, right)):
        return None
    slopes = [median_slope(x[side], h[side], reach_m / 4) for side in (left, right)]
    heights = [float(np.median(h[side] - slope * x[side])) for side, slope in zip((left, right), slopes)]
    return float(abs(np.degrees(np.arctan(slopes[0]) - np.arctan(slopes[1])))), abs(heights[0] - heights[1])


def median_slope(x: np.ndarray, h: np.ndarray, min_run_m: float) -> float:
    """The median of dh / dx over the pairs of points min_run_m or more apart in x (Theil-Sen)."""
    dx, dh = x[None, :] - x[:, None], h[None, :] - h[:, None]
    apart = dx >= min_run_m
    return float(np.median(dh[apart] / dx[apart]))
