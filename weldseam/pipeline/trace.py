"""Trace: a section at every point of a probed chain, and the seam pieces they fit.

A chain's seam joint is the kind most of its sections agree on; a chain where fewer than
`min_valid_fraction` of the sections fit that joint is not a seam (plate outer edges, table
edges, steps, noise). Sections that jump off the line of their neighbours are dropped, and runs
of failed sections longer than `max_gap_m` split the seam.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import TraceConfig
from weldseam.geometry import polyline_length
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import FineSurface, SectionFit, section_frames

# A section's seam point far from the median of this many sections around it jumps off the seam's
# line and is dropped (trace.max_jump_m).
CONSISTENT_WINDOW = 5


@dataclass(frozen=True)
class Hole:
    """A stretch of seam interpolated across a hole in the scan: its middle (3,) and length (m)."""

    middle_m: tuple[float, float, float]
    length_m: float


@dataclass(frozen=True)
class TracedSeam:
    """Seam points (K, 3) and torch axes (K, 3) in travel order, the joint, how sure the trace is
    (0..1), the holes in the scan the seam was interpolated across (weldseam.pipeline.extend),
    for a groove, the median half-width of its opening (m) as traced, and the candidates (chain
    indices) it was traced from."""

    positions_m: np.ndarray
    torch_axes: np.ndarray
    closed: bool
    joint: JointKind
    confidence: float
    holes: tuple[Hole, ...] = ()
    half_opening_m: float = 0.0
    sources: frozenset[int] = frozenset()

    @property
    def length_m(self) -> float:
        """Arc length (m), including the closing segment of a loop."""
        return polyline_length(self.positions_m, self.closed)


def trace_chain(
    chain: Chain, approx_axes: np.ndarray, probe_fits: dict[int, SectionFit], surface: FineSurface,
    params: TraceConfig,
) -> list[TracedSeam]:
    """Seams found along one chain (none if the chain is not a seam): a section at every chain
    point. The chain's probes are sections at some of its points in the same frames, fitted as
    these are: they are not fitted again."""
    travel, axes, lateral = section_frames(chain.points, approx_axes, chain.closed)
    rest = np.array([k for k in range(len(chain.points)) if k not in probe_fits], dtype=int)
    fitted = iter(surface.fit_many(chain.points[rest], travel[rest], axes[rest], lateral[rest]))
    fits = [probe_fits[k] if k in probe_fits else next(fitted) for k in range(len(chain.points))]
    kinds = Counter(fit.kind for fit in fits if fit.kind is not None)
    if not kinds:
        return []
    joint, count = max(sorted(kinds.items()), key=lambda item: item[1])
    confidence = count / len(fits)
    if confidence < params.min_valid_fraction:
        return []
    valid = np.array([fit.kind == joint for fit in fits]) & _consistent([fit.point_m for fit in fits], params.max_jump_m)
    seams = []
    for run, closed in _valid_runs(chain.points, valid, chain.closed, params.max_gap_m):
        run_fits = [fits[i] for i in run]
        seams.append(
            TracedSeam(
                positions_m=np.array([fit.point_m for fit in run_fits]),
                torch_axes=np.array([fit.torch_axis for fit in run_fits]),
                closed=closed,
                joint=joint,
                confidence=round(confidence, 3),
                half_opening_m=float(np.median([fit.half_opening_m for fit in run_fits])),
            )
        )
    return seams


def inside_traced(points: np.ndarray, seams: list[TracedSeam], beside_m: float) -> bool:
    """Whether each of `points` (K, 3) lies inside the opening of one of `seams` or within
    `beside_m` of it: within its half-opening + beside_m of one of its seam points. The crease
    band of a groove often breaks into lines along its edges, and each traces (re-centred) to
    the seam itself: once the seam is traced, tracing such a line again adds nothing."""
    covered = np.zeros(len(points), bool)
    for seam in seams:
        reach = seam.half_opening_m + beside_m
        covered |= cKDTree(seam.positions_m).query(points, distance_upper_bound=reach)[0] <= reach
    return bool(covered.all())


def _consistent(seam_points: list[np.ndarray], max_jump_m: float) -> np.ndarray:
    """False for seam points farther than `max_jump_m` from the median of the
    CONSISTENT_WINDOW sections around them."""
    positions = np.asarray(seam_points)
    if len(positions) < CONSISTENT_WINDOW:
        return np.ones(len(positions), bool)
    half = CONSISTENT_WINDOW // 2
    padded = np.pad(positions, ((half, half), (0, 0)), mode="edge")
    windows = np.stack([padded[k : k + len(positions)] for k in range(CONSISTENT_WINDOW)], axis=1)
    deviation = np.linalg.norm(positions - np.median(windows, axis=1), axis=1)
    return deviation <= max_jump_m


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
