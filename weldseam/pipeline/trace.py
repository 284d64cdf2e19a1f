"""Trace: a section at every point of a probed chain, and the seam pieces they fit.

A chain's seam joint is the kind most of its sections agree on; a chain where fewer than
`min_valid_fraction` of the sections fit that joint is not a seam (plate outer edges, table
edges, steps, noise). Sections that jump off the line of their neighbours are dropped, and runs
of failed sections longer than `max_gap_m` split the seam.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import TraceConfig
from weldseam.geometry import even_indices, polyline_length, unit
from weldseam.pipeline.joints import JointKind, akin, recentred
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import RECENTRE_M, FineSurface, PointFlag, SectionFit, section_frames

# A section's seam point far from the median of this many sections around it jumps off the seam's
# line and is dropped (trace.max_jump_m).
CONSISTENT_WINDOW = 5
INSIDE_FRACTION = 0.8
# A chain whose sections find the seam this far from it (median) is moved onto what they found
# (on_fits), each point by the median offset of this many fits around it.
ON_FITS_WINDOW = 5
# A chain of this many sections or more is first fitted at every COARSE_STRIDE-th one (with its
# probes): where fewer than half trace.min_valid_fraction of those fit any joint, the whole
# chain cannot reach that fraction unless its fits crowd between the samples, and it is not
# fitted further (most candidates are plate and table edges). A chain lying a few mm off its
# joint (follow_fits) is no exception: its sections, 2 half_width_m wide, still find the joint;
# of its fits, only those off the seams traced before count (inside_traced, for where it lies).
COARSE_STRIDE = 4
MIN_COARSE_SECTIONS = 12
# Consecutive seam points of one piece lie at most this many times as far apart as their sections
# (_follows).
MAX_STRETCH = 2.0
OUTLINE_REASON = "a corner with one face unseen whose other face is only an occluder's outline (a shadow's edge?)"


@dataclass(frozen=True)
class Hole:
    """A stretch of seam interpolated across a hole in the scan: its middle (3,) and length (m)."""

    middle_m: tuple[float, float, float]
    length_m: float


@dataclass(frozen=True)
class TracedSeam:
    """Seam points (K, 3) and torch axes (K, 3) in travel order, the joint, how sure the trace is
    (0..1), the holes in the scan the seam was interpolated across (weldseam.pipeline.extend),
    for a groove, the median half-width of its opening (m) as traced, the candidates (chain
    indices) it was traced from, each point's PointFlag bits (None: none), and the median
    across_spread of its fits (JointGeometry: over 1 at a corner of more than 90 degrees)."""

    positions_m: np.ndarray
    torch_axes: np.ndarray
    closed: bool
    joint: JointKind
    confidence: float
    holes: tuple[Hole, ...] = ()
    half_opening_m: float = 0.0
    sources: frozenset[int] = frozenset()
    flags: np.ndarray | None = None
    across_spread: float = 1.0

    @property
    def point_flags(self) -> np.ndarray:
        """(K,) the PointFlag bits of each point (section.PointFlag)."""
        return np.zeros(len(self.positions_m), np.uint8) if self.flags is None else self.flags

    def part(self, index, closed: bool = False) -> TracedSeam:
        """The seam's points at `index` (a slice or index array) as a seam of their own (open unless
        `closed`; the holes it crossed are not carried, the groove's opening is)."""
        return TracedSeam(self.positions_m[index], self.torch_axes[index], closed, self.joint, self.confidence,
                          half_opening_m=self.half_opening_m, sources=self.sources, flags=self.point_flags[index],
                          across_spread=self.across_spread)  # fmt: skip

    def reversed(self) -> TracedSeam:
        """The seam in the opposite travel order."""
        return replace(self, positions_m=self.positions_m[::-1], torch_axes=self.torch_axes[::-1],
                       flags=self.point_flags[::-1])  # fmt: skip

    def samples(self, count: int) -> np.ndarray:
        """Indices of up to `count` of its points, evenly spaced from the first to the last."""
        return even_indices(len(self.positions_m), count)

    @property
    def length_m(self) -> float:
        """Arc length (m), including the closing segment of a loop."""
        return polyline_length(self.positions_m, self.closed)


def end_to_end(a: TracedSeam, between: tuple[np.ndarray, np.ndarray, np.ndarray], b: TracedSeam,
               holes: tuple[Hole, ...] = ()) -> TracedSeam:
    """Open seam `a`, the points `between` its end and b's start ((K, 3) positions, (K, 3) torch
    axes, (K,) PointFlag bits) and open seam `b` as one open seam: the joint of the piece with more
    points; confidence, half-opening and across_spread weighted by the pieces' points (confidence
    to 0.001); both pieces' sources and holes, then `holes`."""
    positions, axes, flags = between
    weight = len(a.positions_m) / (len(a.positions_m) + len(b.positions_m))
    return TracedSeam(
        positions_m=np.vstack([a.positions_m, np.reshape(positions, (-1, 3)), b.positions_m]),
        torch_axes=np.vstack([a.torch_axes, np.reshape(axes, (-1, 3)), b.torch_axes]),
        closed=False,
        joint=a.joint if len(a.positions_m) >= len(b.positions_m) else b.joint,
        confidence=round(weight * a.confidence + (1 - weight) * b.confidence, 3),
        holes=(*a.holes, *b.holes, *holes),
        half_opening_m=weight * a.half_opening_m + (1 - weight) * b.half_opening_m,
        sources=a.sources | b.sources,
        flags=np.concatenate([a.point_flags, np.asarray(flags, np.uint8), b.point_flags]),
        across_spread=weight * a.across_spread + (1 - weight) * b.across_spread,
    )


def trace_chain(
    chain: Chain, approx_axes: np.ndarray, probe_fits: dict[int, SectionFit], surface: FineSurface,
    params: TraceConfig, follow_fits: bool = False, traced: Sequence[TracedSeam] = (), beside_m: float = 0.0,
) -> list[TracedSeam]:
    """Seams found along one chain (none if the chain is not a seam): a section at every chain
    point, seeking the joints its probes found (and their kin, joints.akin). The chain's probes are
    sections at some of its points in the same frames, fitted as these are: they are not fitted
    again. A long chain is fitted coarsely first (COARSE_STRIDE) and given up early where few of
    those sections fit. `follow_fits`: a chain thinned from a band wider than its joint (a wide
    valley's) may lie a few mm off it; where its sections find the seam off it (on_fits), they are
    taken again across the line they found; its coarse sections count only where they find the
    seam outside the seams `traced` before (within their half-opening + `beside_m`): a chain whose
    sections find only those adds nothing, and two more passes over it cost most of a trace; nor do
    its fits there become seam points (a stretch traced once is not traced twice)."""
    travel, axes, lateral = section_frames(chain.points, approx_axes, chain.closed)
    sought = akin({fit.kind for fit in probe_fits.values() if fit.kind is not None}) or None  # none: any
    found = dict(probe_fits)

    def fit_at(indices) -> None:
        at = np.array([k for k in indices if k not in found], dtype=int)
        found.update(zip(at.tolist(), surface.fit_many(chain.points[at], travel[at], axes[at], lateral[at], sought)))

    count = len(chain.points)
    if count >= MIN_COARSE_SECTIONS:
        fit_at(range(0, count, COARSE_STRIDE))
        coarse = [fit for fit in evidence(list(found.values())) if fit.kind is not None]
        if follow_fits and coarse:
            coarse = [fit for fit, known in zip(coarse, covered(np.array([fit.point_m for fit in coarse]), traced,
                                                                beside_m)) if not known]  # fmt: skip
        if len(coarse) / len(found) < params.min_valid_fraction / 2:
            return []
    fit_at(range(count))
    fits = evidence([found[k] for k in range(count)])
    kinds = Counter(fit.kind for fit in fits if fit.kind is not None)
    if not kinds:
        return []
    joint, count = max(sorted(kinds.items()), key=lambda item: item[1])
    # A kind that assumes the joint centred has each section fitted again so already (fit_many).
    moved = on_fits(chain, fits, joint) if follow_fits and not recentred(joint) else None
    if moved is not None:
        chain = moved
        travel, axes, lateral = section_frames(chain.points, approx_axes, chain.closed)
        fits = evidence(surface.fit_many(chain.points, travel, axes, lateral, akin({joint})))
        count = sum(fit.kind == joint for fit in fits)
    confidence = count / len(fits)
    if confidence < params.min_valid_fraction:
        return []
    # A section another model explains better is fitted again seeking the chain's joint only.
    other = np.array([k for k, fit in enumerate(fits) if fit.kind is not None and fit.kind != joint], dtype=int)
    for k, fit in zip(other, evidence(surface.fit_many(chain.points[other], travel[other], axes[other],
                                                       lateral[other], {joint}))):
        fits[k] = fit
    positions, axes = np.array([fit.point_m for fit in fits]), np.array([fit.torch_axis for fit in fits])
    # A shallow corner's point is known less well across than a square one's (across_spread).
    max_offset = params.max_offset_m * np.array([fit.geometry.across_spread for fit in fits])
    valid = np.array([fit.kind == joint for fit in fits]) & consistent(positions, axes, max_offset, params.max_turn_deg)
    if follow_fits:
        valid &= ~covered(positions, traced, beside_m)
    return [_piece([fits[i] for i in run], closed, joint, confidence)
            for run, closed in _valid_runs(chain.points, positions, valid, chain.closed, params.max_gap_m,
                                           max_offset)]  # fmt: skip


def _piece(fits: list[SectionFit], closed: bool, joint: JointKind, confidence: float) -> TracedSeam:
    """The seam of a run of valid `fits`: their points, axes and flags, the medians of their
    half-openings and across_spreads, `confidence` to 0.001."""
    return TracedSeam(
        positions_m=np.array([fit.point_m for fit in fits]),
        torch_axes=np.array([fit.torch_axis for fit in fits]),
        closed=closed,
        joint=joint,
        confidence=round(confidence, 3),
        half_opening_m=float(np.median([fit.half_opening_m for fit in fits])),
        across_spread=float(np.median([fit.geometry.across_spread for fit in fits])),
        flags=np.array([fit.flags for fit in fits], np.uint8),
    )


def evidence(fits: list[SectionFit]) -> list[SectionFit]:
    """`fits` with each corner placed from an occluder's outline (PointFlag.OUTLINE) taken as no
    fit: by itself it may be the edge of a shadow. Only an extension takes it, along the curve of a
    seam's full fits (extend)."""
    return [SectionFit(None, fit.point_m, fit.torch_axis, reason=OUTLINE_REASON) if fit.flags & PointFlag.OUTLINE
            else fit for fit in fits]  # fmt: skip


def on_fits(chain: Chain, fits: list[SectionFit], joint: JointKind) -> Chain | None:
    """The chain moved onto the seam points its sections of `joint` found, where they lie farther
    than RECENTRE_M from it (median), None otherwise or with fewer than three such fits: each
    point moved by the median offset of the fits at it and its neighbours (ON_FITS_WINDOW), the
    offsets interpolated along the chain between the fits (held beyond the first and last)."""
    found = np.array([k for k, fit in enumerate(fits) if fit.kind == joint], dtype=int)
    if len(found) < 3:
        return None
    offsets = np.array([fits[k].point_m for k in found]) - chain.points[found]
    if np.median(np.linalg.norm(offsets, axis=1)) <= RECENTRE_M:
        return None
    half = ON_FITS_WINDOW // 2
    smoothed = np.array([np.median(offsets[max(0, i - half): i + half + 1], axis=0) for i in range(len(found))])
    index = np.arange(len(chain.points))
    shift = np.column_stack([np.interp(index, found, smoothed[:, axis]) for axis in range(3)])
    return Chain(points=chain.points + shift, closed=chain.closed)


def inside_traced(points: np.ndarray, seams: list[TracedSeam], beside_m: float) -> bool:
    """Whether most (INSIDE_FRACTION) of `points` (K, 3) lie inside the opening of one of `seams`
    or within `beside_m` of it: within its half-opening + beside_m of one of its seam points. The
    crease band of a groove often breaks into lines along its edges, and each traces (re-centred)
    to the seam itself: once the seam is traced, tracing such a line again adds nothing that the
    extension of the seam's ends does not (a line along an edge traces the seam less well)."""
    return bool(np.mean(covered(points, seams, beside_m)) >= INSIDE_FRACTION) if len(points) else True


def covered(points: np.ndarray, seams: Sequence[TracedSeam], beside_m: float) -> np.ndarray:
    """(K,) whether each of `points` (K, 3) lies within the half-opening + `beside_m` of a seam
    point of one of `seams`."""
    inside = np.zeros(len(points), bool)
    for seam in seams:
        reach = seam.half_opening_m + beside_m
        inside |= cKDTree(seam.positions_m).query(points, distance_upper_bound=reach)[0] <= reach
    return inside


def consistent(positions: np.ndarray, axes: np.ndarray, max_offset_m, max_turn_deg: float) -> np.ndarray:
    """(K,) False for seam points (K, 3) that jump off the line of their neighbours: farther than
    `max_offset_m` (one for all, or (K,) one per point) from the line through the CONSISTENT_WINDOW
    nearest other points (their mean and principal direction), or whose torch axis (K, 3) is more
    than `max_turn_deg` from those points' median axis. A point is never its own reference: at the ends the neighbours all lie on
    one side (a section at a seam's end is often distorted by the part's end face)."""
    count = len(positions)
    if count <= CONSISTENT_WINDOW:
        return np.ones(count, bool)
    start = np.clip(np.arange(count) - CONSISTENT_WINDOW // 2, 0, count - CONSISTENT_WINDOW - 1)
    window = start[:, None] + np.arange(CONSISTENT_WINDOW + 1)
    others = np.array([row[row != k] for k, row in enumerate(window)])
    neighbours = positions[others]
    centres = neighbours.mean(axis=1)
    direction = np.linalg.svd(neighbours - centres[:, None], full_matrices=False)[2][:, 0]
    offset = positions - centres
    across = offset - np.sum(offset * direction, axis=1, keepdims=True) * direction
    reference = unit(np.median(axes[others], axis=1))
    turn = np.degrees(np.arccos(np.clip(np.sum(axes * reference, axis=1), -1.0, 1.0)))
    return (np.linalg.norm(across, axis=1) <= max_offset_m) & (turn <= max_turn_deg)


def _follows(spacing: np.ndarray, positions: np.ndarray, max_offset_m: np.ndarray) -> np.ndarray:
    """(K - 1,) whether each seam point (K, 3) follows on from the one before: they lie at most
    MAX_STRETCH times as far apart as their sections' centres (`spacing`, K - 1, m), plus the larger
    of their max_offset_m (K,). A seam crossing its chain at up to 60 degrees stretches by at most 2; sections
    a few mm apart whose points lie centimetres apart found two different joints in their windows
    (a clamp's foot, then a corner 2 cm beyond it), which no neighbours outvote in a short chain
    (consistent)."""
    stretch = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    return stretch <= MAX_STRETCH * spacing + np.maximum(max_offset_m[:-1], max_offset_m[1:])


def _valid_runs(centres: np.ndarray, positions: np.ndarray, valid: np.ndarray, closed: bool, max_gap_m: float,
                max_offset_m: np.ndarray):
    """Index runs of valid sections, split where the valid ones are more than max_gap_m apart, or
    where their seam points lie farther apart than _follows allows (two joints, not one seam)."""
    indices = np.flatnonzero(valid)
    if len(indices) < 2:
        return []
    gaps = np.linalg.norm(np.diff(centres[indices], axis=0), axis=1)
    apart = ~_follows(gaps, positions[indices], max_offset_m[indices])
    breaks = np.flatnonzero((gaps > max_gap_m) | apart) + 1
    runs = np.split(indices, breaks)
    if closed:
        ends = [indices[-1], indices[0]]
        wrap_gap = np.linalg.norm(centres[indices[0]] - centres[indices[-1]])
        wraps = bool(wrap_gap <= max_gap_m and _follows(np.array([wrap_gap]), positions[ends], max_offset_m[ends])[0])
        if len(runs) == 1 and wraps:
            return [(runs[0], True)]
        if len(runs) > 1 and wraps:
            runs = [np.concatenate([runs[-1], runs[0]])] + runs[1:-1]
    return [(run, False) for run in runs if len(run) >= 2]
