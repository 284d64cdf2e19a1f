"""Resampling: smooth the seam points along the seam and space poses evenly by arc length."""

from __future__ import annotations

import numpy as np

from weldseam.geometry import arc_lengths, frames_from_axes, unit


def resample_seam(
    positions: np.ndarray, torch_axes: np.ndarray, *, spacing_m: float, smoothing_m: float, closed: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Positions (K, 3) and tool frames (K, 3, 3) every `spacing_m` of arc length.

    Positions and torch axes are first smoothed with a Gaussian of sigma `smoothing_m` in
    arc length (per-section noise averages out; a 90-degree bend is rounded by about
    sigma). Between knots, positions are interpolated linearly and torch axes by normalised
    linear interpolation (slerp to 1e-4 rad for neighbouring axes within 10 degrees). Frame
    y is the travel direction of the resampled line, z the torch axis made perpendicular to
    it, x = y cross z. The path carries the work angle only: the sections measure the axis
    well across the seam, but its tilt along the seam comes from averaged normals that lean
    at grazing views (up to 10 degrees on a pipe's limb); a travel angle is the robot
    shaping's job.
    """
    arc = arc_lengths(positions, closed)
    total = arc[-1]
    if closed:
        positions = np.vstack([positions, positions[:1]])
        torch_axes = np.vstack([torch_axes, torch_axes[:1]])
    positions, torch_axes = _smooth(positions, torch_axes, arc, smoothing_m, total if closed else None)
    count = max(int(round(total / spacing_m)), 1)
    samples = np.linspace(0.0, total, count, endpoint=False) if closed else np.linspace(0.0, total, count + 1)
    new_positions = np.column_stack([np.interp(samples, arc, positions[:, k]) for k in range(3)])
    new_axes = unit(np.column_stack([np.interp(samples, arc, torch_axes[:, k]) for k in range(3)]))
    travel = _chords(new_positions, max(1, int(round(2 * smoothing_m / spacing_m))), closed)
    new_axes = unit(new_axes - np.sum(new_axes * travel, axis=1, keepdims=True) * travel)
    return new_positions, frames_from_axes(new_axes, travel)


def _chords(positions: np.ndarray, k: int, closed: bool) -> np.ndarray:
    """Unit travel directions (K, 3): the chord from k samples behind to k ahead (fewer at
    open ends), steadier than neighbouring differences against sub-millimetre noise."""
    index = np.arange(len(positions))
    if closed:
        ahead, behind = (index + k) % len(positions), (index - k) % len(positions)
    else:
        ahead, behind = np.minimum(index + k, len(positions) - 1), np.maximum(index - k, 0)
    return unit(positions[ahead] - positions[behind])


def _smooth(positions, axes, arc, sigma_m, period):
    """Gaussian-weighted means along arc length (circular distance when `period` is set).
    Near an open end the window is one-sided, so the end point stays where it was measured."""
    if sigma_m <= 0 or len(arc) < 3:
        return positions, axes
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
    return weights @ positions, unit(weights @ axes)


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


def one_face_warning(seam_id: int, length_m: float) -> str:
    """The warning for a corner seen with one face only over `length_m` of seam `seam_id`."""
    return (f"seam {seam_id}: one face of the corner was not seen over {length_m * 1000:.0f} mm (seen too "
            "obliquely): the corner is placed where the other face ends, under the wall's top")
