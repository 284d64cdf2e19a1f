"""Tracing: turn a coarse ordered chain into seam points via cross-sections.

The chain's sections are fitted; the seam's joint is the kind most sections agree on, and
a chain where fewer than `min_valid_fraction` of the sections fit that joint is not a seam
(plate outer edges, table edges, steps, noise). Runs of failed sections longer than
`max_gap_m` split the seam; open ends are extended section by section while the joint
still fits, so the path reaches the seam's real ends and never its end caps.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from weldseam.geometry import unit
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import SectionFit, analyse_sections, section_frames


PROBE_SECTIONS = 5


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
    max_extension_m: float,
    section_params: dict,
) -> list[TracedSeam]:
    """Seams found along one chain (none if the chain is not a seam).

    A few evenly spaced sections are fitted first; when none of them fits a joint the
    chain is rejected without fitting the rest (most candidates are plate or table edges).
    """
    travel, axes, lateral = section_frames(chain.points, approx_axes, chain.closed)
    probes = np.unique(np.linspace(0, len(chain.points) - 1, PROBE_SECTIONS).round().astype(int))
    probe_fits = analyse_sections(points, tree, chain.points[probes], travel[probes], axes[probes], lateral[probes], **section_params)
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
        if not closed:
            run_fits = _extend(run_fits, joint, points, tree, step_m, max_extension_m, section_params)
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


def _extend(fits: list[SectionFit], joint, points, tree, step_m, max_extension_m, section_params) -> list[SectionFit]:
    """Add sections beyond both ends while they fit the same joint near the predicted place."""
    for at_start in (True, False):
        ordered = fits[::-1] if at_start else fits
        added = []
        last, before = ordered[-1], ordered[-2]
        direction = unit(last.point_m - before.point_m)
        for _ in range(int(max_extension_m / step_m)):
            predicted = last.point_m + step_m * direction
            travel = direction[None]
            axes = unit(last.torch_axis[None] - (last.torch_axis @ direction) * travel)
            lateral = np.cross(travel, axes)
            fit = analyse_sections(points, tree, predicted[None], travel, axes, lateral, **section_params)[0]
            if fit.joint != joint or np.linalg.norm(fit.point_m - predicted) > 0.5 * step_m:
                break
            added.append(fit)
            direction = unit(fit.point_m - last.point_m)
            last = fit
        ordered = ordered + added
        fits = ordered[::-1] if at_start else ordered
    return fits


def deduplicate(seams: list[TracedSeam], *, tolerance_m: float, min_length_m: float) -> list[TracedSeam]:
    """Keep one copy of seams that several chains traced: a seam with most of its points
    within `tolerance_m` of a longer kept seam is the same seam. Seams shorter than
    `min_length_m` are dropped. Longest first, so the result order is deterministic."""
    def length(seam: TracedSeam) -> float:
        return float(np.linalg.norm(np.diff(seam.positions_m, axis=0), axis=1).sum())

    kept: list[TracedSeam] = []
    for seam in sorted(seams, key=lambda s: (-length(s), tuple(s.positions_m[0]))):
        if length(seam) < min_length_m:
            continue
        duplicate = any(
            np.mean(cKDTree(other.positions_m).query(seam.positions_m)[0] <= tolerance_m) > 0.5 for other in kept
        )
        if not duplicate:
            kept.append(seam)
    return kept
