"""Resampling: smooth the seam points along the seam and space poses evenly by arc length."""

from __future__ import annotations

import numpy as np

from weldseam.geometry import arc_lengths, frames_from_axes, unit
from weldseam.pipeline.joints import JointKind

# The travel is fitted over this many times the positions' Gaussian (_steady_travel), except where
# the seam turns too sharply for a quadratic over that width: where it strays from the samples by
# more than KINK_M (rms, weighted), half a wire diameter, the tolerance the path itself must hold.
# Measured: 0.06-0.24 mm along curved grooves, tubes, rings and saddles; 0.6-1.0 mm within a few
# mm of a groove's 90-degree turn over a block's edge.
WIDE_TRAVEL = 2.0
KINK_M = 0.0005
# A Gaussian of sigma s moves a curve of radius R inward by about s^2 / 2R: a shallow corner's
# positions are smoothed wider only as far as that stays under this (a saddle's 30-40 mm curve
# allows no more than the usual sigma; a valley along a tube's length, many times it).
CURVE_CUT_M = 0.0001


def resample_seam(
    positions: np.ndarray, torch_axes: np.ndarray, *, spacing_m: float, smoothing_m: float, closed: bool,
    across_spread: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Positions (K, 3) and tool frames (K, 3, 3) every `spacing_m` of arc length.

    Positions and torch axes are first smoothed with a Gaussian of sigma `smoothing_m` in
    arc length (per-section noise averages out; a 90-degree bend is rounded by about
    sigma), the positions of a seam whose points are known `across_spread` times less well across
    than its faces are in depth (a shallow corner: JointGeometry.across_spread) over up to that many
    times as much: its faces' ripple and depth steps move its point across by as much more, in
    bumps a few cm long along it (a 130-150 degree valley: 1-2 mm, where its faces move 0.5); as
    far as its curve allows (CURVE_CUT_M).
    Between knots, positions are interpolated linearly and torch axes by normalised linear
    interpolation (slerp to 1e-4 rad for neighbouring axes within 10 degrees). Frame y is the
    travel direction of the resampled line, z the torch axis made perpendicular to it, x = y
    cross z. The path carries the work angle only: the sections measure the axis well across the
    seam, but its tilt along the seam comes from averaged normals that lean at grazing views (up
    to 10 degrees on a pipe's limb); a travel angle is the robot shaping's job.
    """
    arc = arc_lengths(positions, closed)
    total = arc[-1]
    if closed:
        positions = np.vstack([positions, positions[:1]])
        torch_axes = np.vstack([torch_axes, torch_axes[:1]])
    period = total if closed else None
    torch_axes = unit(_smooth(torch_axes, arc, smoothing_m, period))
    line = _smooth(positions, arc, smoothing_m, period)
    wide = smoothing_m * across_spread
    if wide > smoothing_m:
        wide = min(wide, np.sqrt(2 * _radius_m(line, arc, wide) * CURVE_CUT_M))
    positions = _smooth(positions, arc, wide, period) if wide > smoothing_m else line
    count = max(int(round(total / spacing_m)), 1)
    samples = np.linspace(0.0, total, count, endpoint=False) if closed else np.linspace(0.0, total, count + 1)
    new_positions = np.column_stack([np.interp(samples, arc, positions[:, k]) for k in range(3)])
    new_axes = unit(np.column_stack([np.interp(samples, arc, torch_axes[:, k]) for k in range(3)]))
    # The samples' own arc lengths: smoothing shortens a noisy line, so the knots' arc overstates them.
    sampled_arc = arc_lengths(new_positions, closed)
    travel = _steady_travel(new_positions, sampled_arc[: len(new_positions)], smoothing_m,
                            sampled_arc[-1] if closed else None)  # fmt: skip
    new_axes = unit(new_axes - np.sum(new_axes * travel, axis=1, keepdims=True) * travel)
    return new_positions, frames_from_axes(new_axes, travel)


def _radius_m(positions: np.ndarray, arc: np.ndarray, spacing_m: float) -> float:
    """The median radius of curvature (m) of a line (K, 3) at arc lengths `arc` (K,): of the circles
    through its points at three consecutive arc lengths 2 `spacing_m` apart (inf on a straight
    line, or a line too short for three)."""
    samples = np.arange(0.0, arc[-1] + 1e-12, 2 * spacing_m)
    if len(samples) < 3:
        return float("inf")
    points = np.column_stack([np.interp(samples, arc, positions[:, k]) for k in range(3)])
    a, b, c = points[:-2], points[1:-1], points[2:]
    twice_area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    sides = np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1) * np.linalg.norm(c - a, axis=1)
    with np.errstate(divide="ignore"):
        return float(np.median(np.where(twice_area > 0, sides / (2 * twice_area), np.inf)))


def _steady_travel(positions: np.ndarray, arc: np.ndarray, reach_m: float, period: float | None) -> np.ndarray:
    """Unit travel directions (K, 3): _travel over WIDE_TRAVEL x `reach_m`, except where the seam
    turns too sharply for a quadratic over that width (its weighted rms distance from the samples
    over KINK_M): there over `reach_m`. The torch axis is made perpendicular to the travel, so a
    travel tilted by the seam points' scatter tilts the axis as much: a 0.5 mm scatter in depth
    along a saddle tilts it by 2.1 degrees over 3 mm, by 1.5 over 6 (mean). A curve of 25 mm
    radius (a saddle's) stays a quadratic over either; a groove's 90-degree turn over a block's
    edge does not, and the wide travel would lean 10 degrees toward the other face 8-12 mm from
    it. Near an open end the wide quadratic is centred as near the end as the narrow one (its
    window then one-sided): centred farther in, a short piece's ends would take its middle's."""
    local = positions - positions.mean(axis=0)  # the residuals lose no digits to the distance
    narrow, _ = _travel(local, arc, reach_m, period)
    wide, wide_rms = _travel(local, arc, WIDE_TRAVEL * reach_m, period, inner_m=2 * reach_m)
    smooth = wide_rms <= KINK_M
    return np.where(smooth[:, None], wide, narrow)


def _travel(positions: np.ndarray, arc: np.ndarray, reach_m: float, period: float | None,
            inner_m: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Unit travel directions (K, 3) of a line sampled at `positions` (K, 3), arc lengths `arc`
    (K,): the slope at each sample of the quadratic p(s) = c0 + c1 s + c2 s^2 fitted by least
    squares with Gaussian weights of sigma `reach_m` in arc length around a centre: the sample
    itself, or on an open line within `inner_m` (default 2 sigma) of an end, the point that far
    in from that end (a window that holds samples on both sides; fitted at the end itself, the
    quadratic's slope swings with the noise of the last few points), the slope there carried to
    the sample along the quadratic (c1 + 2 c2 (s - centre)). Unlike a chord, unbent by a seam's
    curve, also at its ends, where a chord from the samples on one side tilts the torch along a
    3-D curve by degrees.
    Circular distance with `period` (a closed line). Two samples: their chord. Also each fit's
    weighted rms distance (m) from the samples (K,)."""
    if len(positions) < 3:
        chord = np.broadcast_to(unit(positions[-1] - positions[0]), positions.shape).copy()
        return chord, np.zeros(len(positions))
    centre = arc
    if period is None:
        inner = 2 * reach_m if inner_m is None else inner_m
        centre = np.clip(arc, min(inner, arc[-1] / 2), max(arc[-1] - inner, arc[-1] / 2))
    offset = arc[None, :] - centre[:, None]
    if period is not None:
        offset = (offset + period / 2) % period - period / 2
    weighted = [np.exp(-0.5 * (offset / reach_m) ** 2)]  # w s^power for power 0..4, each (K, K)
    for _ in range(4):
        weighted.append(weighted[-1] * offset)
    moments = [np.add.reduce(term, axis=1) for term in weighted]
    normal = np.stack([np.stack(moments[row : row + 3], axis=-1) for row in range(3)], axis=-2)  # (K, 3, 3)
    right = np.stack([term @ positions for term in weighted[:3]], axis=1)  # (K, 3 powers, 3 xyz)
    coefficients = np.linalg.solve(normal, right)
    # sum w |p - c0 - c1 s - c2 s^2|^2 = sum w |p|^2 - sum_k c_k . (sum w s^k p) at the optimum.
    squares = weighted[0] @ np.sum(positions * positions, axis=1)
    residual = np.maximum(squares - np.einsum("kpx,kpx->k", coefficients, right), 0.0)
    rms = np.sqrt(residual / moments[0])
    return unit(coefficients[:, 1, :] + 2 * (arc - centre)[:, None] * coefficients[:, 2, :]), rms


def _smooth(values, arc, sigma_m, period):
    """Gaussian-weighted means (K, 3) of `values` along arc length (circular distance when
    `period` is set). Near an open end the window is one-sided, so the end point stays where it
    was measured."""
    if sigma_m <= 0 or len(arc) < 3:
        return values
    distance = arc[:, None] - arc[None, :]
    if period is not None:
        distance = (distance + period / 2) % period - period / 2
    weights = np.exp(-0.5 * (distance / sigma_m) ** 2)
    if period is not None:
        weights[:, -1] = 0.0  # the closing copy of the first point is not a second sample
    else:
        reach = np.minimum(arc, arc[-1] - arc)  # keep the window symmetric: no pull at the ends
        weights *= np.abs(distance) <= np.maximum(reach, 1e-12)[:, None] + 1e-12
    weights /= weights.sum(axis=1, keepdims=True)
    return weights @ values


def hole_warning(seam_id: int, hole) -> str:
    """The warning for a stretch of seam `seam_id` interpolated across a hole (trace.Hole)."""
    x, y, z = hole.middle_m
    return (f"seam {seam_id}: {hole.length_m * 1000:.0f} mm interpolated across a hole in the scan "
            f"(no data on the seam) around ({x:.3f}, {y:.3f}, {z:.3f}) m")  # fmt: skip


def resample_flags(positions: np.ndarray, flags: np.ndarray, *, spacing_m: float, closed: bool) -> np.ndarray:
    """(K,) the flags of the poses resample_seam places along `positions` (the same samples): each
    pose takes the bits of the two seam points around it (an OR)."""
    arc = arc_lengths(positions, closed)
    total = arc[-1]
    count = max(int(round(total / spacing_m)), 1)
    samples = np.linspace(0.0, total, count, endpoint=False) if closed else np.linspace(0.0, total, count + 1)
    knots = np.r_[flags, flags[:1]] if closed else flags
    after = np.clip(np.searchsorted(arc, samples, side="right"), 0, len(knots) - 1)
    return knots[after] | knots[np.maximum(after - 1, 0)]


def one_face_warning(seam_id: int, length_m: float, joint: JointKind) -> str:
    """The warning for a corner (of kind `joint`) seen with one face only over `length_m` of seam
    `seam_id`."""
    placed = ("the unseen face is taken square to the seen one, the seam between the V's edges"
              if joint == JointKind.OUTSIDE_CORNER else "the corner is placed where the other face ends, under the wall's top")
    return f"seam {seam_id}: one face of the corner was not seen over {length_m * 1000:.0f} mm (seen too obliquely): {placed}"
