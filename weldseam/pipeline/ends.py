"""Where a seam line goes at its ends: the outward direction, the tangent and curvature, the
seam predicted ahead along that curve, and whether a corner with one face unseen lies on the
curve at the last fit with both faces seen (extend, join)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.geometry import arc_lengths, unit
from weldseam.pipeline.section import PointFlag

# The stretch of seam an end's direction is taken over (the last few points alone are too noisy).
END_BASELINE_M = 0.012
# The stretch an end's tangent and curvature are fitted over.
TANGENT_BASELINE_M = 0.032
# The tightest bend an end's curve predicts (the curvature of a noisy end is clamped to it).
MIN_BEND_RADIUS_M = 0.03
# A corner fitted with one face unseen lies at most this share of its arc from the last fit with
# both faces seen off the curve fitted there, or CURVE_FLOOR_M. Past a standing pipe's silhouette
# the plate's visible end (the shadow's edge) runs on along the line of sight, straight: it
# leaves a ring of radius R by d^2 / 2R, 12.5 % of d at d = R / 4. The curve (a parabola, its
# bend clamped at MIN_BEND_RADIUS_M) stays within 8 % of d of a 50 mm ring for 34 mm, and of a
# 25 mm ring. Near the anchor, within CURVE_FLOOR_M (half an extension step): the curve's noise.
ONE_FACE_DRIFT = 0.08
CURVE_FLOOR_M = 0.001
# Near the anchor the floor is widened by this many times the rms scatter of the fits the curve
# was fitted to (end_fit): the anchor is one of them, and the curve leans with them.
CURVE_SIGMAS = 2.0
# The curve fitted to a tight ring's end bends too little: a quadratic over TANGENT_BASELINE_M of a
# ring of 30 mm bends at 35 mm, of 25 mm or less at the 30 mm clamp (MIN_BEND_RADIUS_M), of 40 mm
# or more within 4 mm of it. So a curve bent at RING_FIT_RADIUS_M or tighter may be a ring down
# to MIN_RING_RADIUS_M (round a pipe of DN25, 33.7 mm across) which runs inside it: a saddle on a
# 26 mm branch pipe fits at 31-34 mm on real fits, its seam 2.3-4.3 mm inside the curve 15-25 mm
# on. A flatter curve follows its seam, and a shadow's edge leaves a ring straight, outside it.
RING_FIT_RADIUS_M = 0.035
MIN_RING_RADIUS_M = 0.017
# Where the camera sees this much past the seam line of a joint whose seam point lies on the part's
# surfaces (joints.ON_SURFACE), the part is not there: their own faces, with 1-2 mm of ripple and
# depth steps, lie within -5..+1.6 mm of it along the line of sight over the corner ends of seeds
# 0-4 (fillet, lap, pipe on plate, saddle); past a part's end it sees the table or a fixture
# 5-260 mm beyond.
CORNER_PAST_M = 0.004


def end_direction(points: np.ndarray, at_start: bool) -> np.ndarray:
    """Outward unit direction at one end of `points` (K, 3): the principal direction of the
    points within END_BASELINE_M of arc from the end, pointing out."""
    ordered = points if at_start else points[::-1]
    arc = arc_lengths(ordered)
    k = max(1, min(int(np.searchsorted(arc, END_BASELINE_M)), len(ordered) - 1))
    chord = ordered[0] - ordered[k]
    window = ordered[: k + 1] - ordered[: k + 1].mean(axis=0)
    direction = np.linalg.svd(window, full_matrices=False)[2][0] if k >= 2 else chord
    return unit(direction if direction @ chord >= 0 else -direction)


def end_curve(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangent t and curvature vector k (1/m, perpendicular to t) at the last of `points`
    (in travel order), from a quadratic p(s) = a + b s + c s^2 fitted over the last
    TANGENT_BASELINE_M of arc: t = -b/|b|, k = 2c without its component along t, at most
    1/MIN_BEND_RADIUS_M. The seam ahead is predicted as p + d t + d^2 k / 2 (ahead). A chord
    or principal direction over that stretch of a curve of radius R leans back by baseline / 2R
    (0.1 rad over 12 mm at R = 60 mm), which is 0.2 mm sideways per 2 mm step."""
    tangent, bend, _ = end_fit(points)
    return tangent, bend


def end_fit(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """end_curve's tangent and curvature vector, and the rms distance (m) of the last
    TANGENT_BASELINE_M of arc of `points` (travel order) from that quadratic, from one fit; with
    fewer than 5 points there, the end's direction (end_direction), no bend and no scatter."""
    window, design = _end_window(points)
    if len(window) < 5:
        return end_direction(points, at_start=False), np.zeros(3), 0.0
    coefficients = np.linalg.lstsq(design, window, rcond=None)[0]
    residual = window - design @ coefficients
    scatter = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
    tangent = unit(-coefficients[1])
    bend = 2 * coefficients[2]
    bend -= (bend @ tangent) * tangent
    size = np.linalg.norm(bend)
    return tangent, bend * min(1.0, 1.0 / (MIN_BEND_RADIUS_M * size)) if size > 0 else bend, scatter


def _end_window(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points (K, 3) of the last TANGENT_BASELINE_M of arc of `points` (in travel order), the
    last first, and the design matrix [1, s, s^2] (K, 3) of their arc lengths s back from it."""
    ordered = points[::-1]
    arc = arc_lengths(ordered)
    window = ordered[arc <= TANGENT_BASELINE_M]
    s = arc[: len(window)]
    return window, np.column_stack([np.ones_like(s), s, s * s])


def ahead(last_point, direction, bend, distance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The predicted seam point `distance_m` on along the curve (end_curve) and its travel."""
    return last_point + distance_m * direction + 0.5 * distance_m**2 * bend, unit(direction + distance_m * bend)


def sideways_reach_m(step_m: float, distance_m: float) -> float:
    """How far (m) sideways of the curve predicted `distance_m` ahead (ahead) a fit may lie and
    still be the seam, for an extension stepping `step_m`: max(1.5 steps, 15 % of the distance).
    Near an end the prediction drifts by 1-3 mm; the bound follows curves of radius down to
    ~40 mm across the longest skip."""
    return max(1.5 * step_m, 0.15 * distance_m)


def offsets(point, predicted, travel, axis) -> tuple[float, float]:
    """(depth, sideways): the offsets (m) of `point` from `predicted` along the torch `axis`
    (made perpendicular to `travel`) and across it."""
    axis = unit(axis - (axis @ travel) * travel)
    offset = point - predicted
    depth = abs(offset @ axis)
    return depth, np.linalg.norm(offset - (offset @ axis) * axis)


@dataclass(frozen=True)
class SeamLine:
    """The straight line through a seam's last stretch: a point on it and its unit direction."""

    point: np.ndarray
    direction: np.ndarray

    def holds(self, point: np.ndarray, axis: np.ndarray, step_m: float) -> bool:
        """Whether `point` (3,) lies within 1.5 steps of the line sideways (across the torch `axis`
        made perpendicular to the line) and half a step along the axis."""
        foot = self.point + ((point - self.point) @ self.direction) * self.direction
        depth, sideways = offsets(point, foot, self.direction, axis)
        return bool(depth <= 0.5 * step_m and sideways <= 1.5 * step_m)


def seam_line(points: np.ndarray) -> SeamLine | None:
    """The line fitted (centroid, principal direction) to the last TANGENT_BASELINE_M of arc of
    `points` (K, 3, travel order), pointing on; None with fewer than 5 points there."""
    if len(points) < 5:
        return None
    window = _end_window(points)[0]
    if len(window) < 5:
        return None
    centre = window.mean(axis=0)
    direction = np.linalg.svd(window - centre, full_matrices=False)[2][0]
    return SeamLine(centre, direction if direction @ (window[0] - window[-1]) >= 0 else -direction)


def on_curve(anchor, direction, bend, arc_m: float, point, axis, scatter_m: float = 0.0) -> bool:
    """Whether `point` (3,), `arc_m` on along a seam from `anchor` (3,), lies within
    b = max(CURVE_FLOOR_M + CURVE_SIGMAS x `scatter_m`, ONE_FACE_DRIFT x arc) of the curve there
    (end_curve's `direction` and `bend` at the anchor: ahead), sideways of the torch `axis`;
    `scatter_m`: the rms distance of the points the curve was fitted to from it (end_fit).
    The anchor is one of those points, and near it the curve is as uncertain as they scatter (the
    last full fits at a saddle's flank scatter 0.2-0.5 mm, the curve through them misses the
    seam by 1-2 mm over the next 4-8 mm); farther on, the drift allowance covers that. Where the
    curve bends as tightly as a ring's does, the point may also lie farther inside it, as far as
    a tighter ring would (_inside_tighter_ring)."""
    predicted, travel = ahead(anchor, direction, bend, arc_m)
    _, sideways = offsets(point, predicted, travel, axis)
    band = max(CURVE_FLOOR_M + CURVE_SIGMAS * scatter_m, ONE_FACE_DRIFT * arc_m)
    if sideways <= band:
        return True
    return _inside_tighter_ring(predicted, travel, axis, bend, arc_m, point, band)


def _inside_tighter_ring(predicted, travel, axis, bend, arc_m: float, point, band_m: float) -> bool:
    """Whether `point` lies off the curve's `predicted` point (its `travel` there) toward the inside
    of its `bend` by at most band_m + arc^2 / 2 x (1 / MIN_RING_RADIUS_M - |bend|), and within
    band_m of it in every other direction across the torch `axis` (along the travel too: a ring's
    fits keep pace with its curve); only where the curve bends at RING_FIT_RADIUS_M or tighter."""
    size = float(np.linalg.norm(bend))
    if size < 1.0 / RING_FIT_RADIUS_M:
        return False
    inside = bend - (bend @ travel) * travel
    axis = unit(axis - (axis @ travel) * travel)
    inside -= (inside @ axis) * axis
    if not inside.any():
        return False
    inside = unit(inside)
    offset = point - predicted
    offset -= (offset @ axis) * axis
    inward = float(offset @ inside)
    lag = 0.5 * arc_m**2 * (1.0 / MIN_RING_RADIUS_M - size)
    return -band_m <= inward <= band_m + lag and float(np.linalg.norm(offset - inward * inside)) <= band_m


# What a full fit is not: a corner with one face unseen, or an outline that misses the points.
NOT_FULL = PointFlag.ONE_FACE | PointFlag.ROUGH


def last_full(positions: np.ndarray, flags: np.ndarray | None) -> tuple:
    """(index, direction, bend, scatter) of a seam's last point fitted with both faces seen and its
    outline near the points (no NOT_FULL bit; `flags`: its points' PointFlag bits, None: all were
    so), the curve of the seam up to it and that curve's scatter (end_fit); ()
    when there is none (a T-joint seen from above all along: its one-face corners are the seam)."""
    full = np.arange(len(positions)) if flags is None else np.flatnonzero((np.asarray(flags) & NOT_FULL) == 0)
    if len(full) == 0 or full[-1] < 1:
        return ()
    return (int(full[-1]), *end_fit(positions[: full[-1] + 1]))
