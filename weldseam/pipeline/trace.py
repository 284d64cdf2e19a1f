"""Tracing: turn a coarse ordered chain into seam points via cross-sections.

A chain's sections are fitted; the seam's joint is the kind most sections agree on, and
a chain where fewer than `min_valid_fraction` of the sections fit that joint is not a seam
(plate outer edges, table edges, steps, noise). Runs of failed sections longer than
`max_gap_m` split the seam. `extend_seam` carries a seam's open ends section by section to
the seam's real ends (never its end caps).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from weldseam.geometry import arc_lengths, polyline_length, unit
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import analyse_sections, section_frames

PROBE_SECTIONS = 3
END_BASELINE_M = 0.012


@dataclass(frozen=True)
class TracedSeam:
    """Seam points (K, 3) and torch axes (K, 3) in travel order."""

    positions_m: np.ndarray
    torch_axes: np.ndarray
    closed: bool
    joint: str
    confidence: float


def trace_chain(
    chain: Chain,
    approx_axes: np.ndarray,
    points: np.ndarray,
    tree,
    *,
    step_m: float,
    max_gap_m: float,
    min_valid_fraction: float,
    section_params: dict,
) -> list[TracedSeam]:
    """Seams found along one chain (none if the chain is not a seam).

    Three evenly spaced sections are fitted first; when none of them fits a joint the
    chain is rejected without fitting the rest (most candidates are plate or table edges).
    """
    travel, axes, lateral = section_frames(chain.points, approx_axes, chain.closed)
    probes = np.unique(np.linspace(0, len(chain.points) - 1, PROBE_SECTIONS).round().astype(int))
    probe_fits = analyse_sections(
        points, tree, chain.points[probes], travel[probes], axes[probes], lateral[probes], **section_params
    )
    if not any(fit.joint for fit in probe_fits):
        return []
    fits = analyse_sections(points, tree, chain.points, travel, axes, lateral, **section_params)
    kinds = Counter(fit.joint for fit in fits if fit.joint)
    if not kinds:
        return []
    joint, count = max(sorted(kinds.items()), key=lambda item: item[1])
    confidence = count / len(fits)
    if confidence < min_valid_fraction:
        return []
    valid = np.array([fit.joint == joint for fit in fits]) & _consistent([fit.point_m for fit in fits], step_m)
    seams = []
    for run, closed in _valid_runs(chain.points, valid, chain.closed, max_gap_m):
        run_fits = [fits[i] for i in run]
        seams.append(
            TracedSeam(
                positions_m=np.array([fit.point_m for fit in run_fits]),
                torch_axes=np.array([fit.torch_axis for fit in run_fits]),
                closed=closed,
                joint=joint,
                confidence=round(confidence, 3),
            )
        )
    return seams


def _consistent(seam_points: list[np.ndarray], step_m: float) -> np.ndarray:
    """False for seam points that jump off the line of their neighbours: farther than
    max(1 mm, 2 steps) from the median of the 5 sections around them."""
    positions = np.asarray(seam_points)
    if len(positions) < 5:
        return np.ones(len(positions), bool)
    padded = np.pad(positions, ((2, 2), (0, 0)), mode="edge")
    windows = np.stack([padded[k : k + len(positions)] for k in range(5)], axis=1)
    deviation = np.linalg.norm(positions - np.median(windows, axis=1), axis=1)
    return deviation <= max(0.001, 2 * step_m)


def _valid_runs(centres: np.ndarray, valid: np.ndarray, closed: bool, max_gap_m: float):
    """Index runs of valid sections, split where the valid ones are more than max_gap_m apart."""
    indices = np.flatnonzero(valid)
    if len(indices) < 2:
        return []
    gaps = np.linalg.norm(np.diff(centres[indices], axis=0), axis=1)
    breaks = np.flatnonzero(gaps > max_gap_m) + 1
    runs = np.split(indices, breaks)
    if closed:
        wrap_gap = np.linalg.norm(centres[indices[0]] - centres[indices[-1]])
        if len(runs) == 1 and wrap_gap <= max_gap_m:
            return [(runs[0], True)]
        if len(runs) > 1 and wrap_gap <= max_gap_m:
            runs = [np.concatenate([runs[-1], runs[0]])] + runs[1:-1]
    return [(run, False) for run in runs if len(run) >= 2]


def end_direction(points: np.ndarray, at_start: bool) -> np.ndarray:
    """Outward unit direction at one end: the principal direction of the points within
    ~12 mm of arc from the end, pointing out (the last few points alone are too noisy)."""
    ordered = points if at_start else points[::-1]
    arc = arc_lengths(ordered)
    k = max(1, min(int(np.searchsorted(arc, END_BASELINE_M)), len(ordered) - 1))
    chord = ordered[0] - ordered[k]
    window = ordered[: k + 1] - ordered[: k + 1].mean(axis=0)
    direction = np.linalg.svd(window, full_matrices=False)[2][0] if k >= 2 else chord
    return unit(direction if direction @ chord >= 0 else -direction)


def extend_seam(
    seam: TracedSeam, points, tree, *, step_m: float, max_gap_m: float, max_extension_m: float, section_params: dict
) -> TracedSeam:
    """The seam with sections added beyond both open ends while they fit its joint near
    the predicted place, so the path reaches the seam's real ends.

    A section that fails (a hole, a spatter blob) is stepped over; the extension stops after
    `max_gap_m` without a fit. A fit counts when it lies within max(1.5 steps, 15 % of the
    distance from the last fit) of the straight-line prediction sideways (the fit is a
    verified joint profile and the better estimate: near an end the prediction drifts by
    1-3 mm; the bound follows curves of radius down to ~40 mm across the largest gap), and
    within half a step along the torch axis (the surface does not jump; a section that
    straddles the part's end face does). An extension stops where it comes within two steps
    of the seam itself (it has gone round a loop; the ends then meet and the seam closes). Run
    on joined seams only: extending every partial trace would walk the same seam once per piece.
    """
    if seam.closed or len(seam.positions_m) < 2:
        return seam
    positions, axes = list(seam.positions_m), list(seam.torch_axes)
    for at_start in (True, False):
        if at_start:
            positions.reverse()
            axes.reverse()
        direction = end_direction(np.array(positions), at_start=False)
        last_point, last_axis = positions[-1], axes[-1]
        # The seam away from this end: an extension that reaches it has gone round a loop.
        arc = arc_lengths(np.array(positions))
        elsewhere = np.array(positions)[arc < arc[-1] - 2 * END_BASELINE_M]
        for _ in range(int(max_extension_m / step_m)):
            distance = step_m
            while distance <= max_gap_m:
                predicted = last_point + distance * direction
                axis = unit(last_axis[None] - (last_axis @ direction) * direction[None])
                fit = analyse_sections(
                    points, tree, predicted[None], direction[None], axis, np.cross(direction[None], axis),
                    **section_params,
                )[0]
                offset = fit.point_m - predicted
                depth = abs(offset @ axis[0])
                sideways = np.linalg.norm(offset - (offset @ axis[0]) * axis[0])
                if fit.joint == seam.joint and sideways <= max(1.5 * step_m, 0.15 * distance) and depth <= 0.5 * step_m:
                    break
                distance += step_m
            else:
                break
            if len(elsewhere) and np.min(np.linalg.norm(elsewhere - fit.point_m, axis=1)) <= 2 * step_m:
                break
            positions.append(fit.point_m)
            axes.append(fit.torch_axis)
            # Re-aim along the last 12 mm: one 2 mm step alone is ~10 degrees noisy.
            direction = end_direction(np.array(positions), at_start=False)
            last_point, last_axis = fit.point_m, fit.torch_axis
        if at_start:
            positions.reverse()
            axes.reverse()
    return TracedSeam(np.array(positions), np.array(axes), False, seam.joint, seam.confidence)


def seam_length(seam: TracedSeam) -> float:
    """Arc length (m), including the closing segment of a loop."""
    return polyline_length(seam.positions_m, seam.closed)


