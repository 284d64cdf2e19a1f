"""Probe: a few sections along every candidate chain, before tracing any of them.

Most candidates are plate or table edges; a chain where none of its probe sections fits a joint
is not a seam, and is rejected without fitting a section at every point. The probes are fitted
in one batch for all chains (half on the worker process) and reused by the trace.
"""

from __future__ import annotations

import itertools

import numpy as np

from weldseam.geometry import even_indices, polyline_length, unit
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import FineSurface, SectionFit, section_frames

PROBE_SECTIONS = 3


def approximate_torch_axes(centres: list[np.ndarray], normals, tree, radius_m) -> list[np.ndarray]:
    """For each (K, 3) array of `centres`, the negated mean normal of the working surface within
    `radius_m` of each centre (`tree` over the points that have the (N, 3) `normals`): the plate
    normal beside a groove, the bisector of the faces at a corner; pointing into the work. One
    search for all (each search starts its own threads)."""
    if not centres:
        return []
    everywhere = np.concatenate(centres)
    neighbourhoods = tree.query_ball_point(everywhere, radius_m, workers=-1)
    counts = np.fromiter(map(len, neighbourhoods), np.intp, len(neighbourhoods))
    members = np.fromiter(itertools.chain.from_iterable(neighbourhoods), np.intp, counts.sum())
    owner = np.repeat(np.arange(len(everywhere)), counts)
    # bincount adds each centre's normals in member order, as a sum over them would.
    sums = np.column_stack([np.bincount(owner, normals[members, k], len(everywhere)) for k in range(3)])
    return np.split(unit(-sums), np.cumsum([len(c) for c in centres])[:-1])


def probe_chains(
    chains: list[Chain], approx_axes: list[np.ndarray], surface: FineSurface,
    sought: list[frozenset[JointKind] | None] | None = None, min_length_m: float = 0.0, stretch_m: float = 0.0,
) -> list[dict[int, SectionFit]]:
    """For each chain, the fits of sections along it seeking its `sought` kinds (None: any kind,
    for one chain or all), by chain point index, in the frames trace_chain uses (so it reuses
    them); none for a chain shorter than `min_length_m` (the trace rejects it unprobed).
    PROBE_SECTIONS evenly spaced from end to end, or one per `stretch_m` of a shorter chain (the
    trace's max_gap_m: sections within one such stretch are one place to it), one in the middle
    of a chain shorter than that. One batch per distinct `sought`."""
    sought = [None] * len(chains) if sought is None else sought
    frames = {}
    for k, (chain, axes) in enumerate(zip(chains, approx_axes)):
        length = polyline_length(chain.points, chain.closed)
        if length < min_length_m:
            continue
        travel, frame_axes, lateral = section_frames(chain.points, axes, chain.closed)
        count = min(PROBE_SECTIONS, 1 + int(length / stretch_m)) if stretch_m > 0 else PROBE_SECTIONS
        at = even_indices(len(chain.points), count) if count > 1 else np.array([len(chain.points) // 2])
        frames[k] = (at, (chain.points[at], travel[at], frame_axes[at], lateral[at]))
    probes = [{} for _ in chains]
    for kinds in dict.fromkeys(sought[k] for k in frames):
        batch = [k for k in frames if sought[k] == kinds]
        fits = iter(surface.fit_many(*(np.concatenate(part) for part in zip(*(frames[k][1] for k in batch))), kinds))
        for k in batch:
            probes[k] = {int(index): next(fits) for index in frames[k][0]}
    return probes


def tracing_order(chain: Chain, probes: dict[int, SectionFit]) -> tuple:
    """Sort key of a probed chain: the chains whose probes most often fit, then those lying closest
    to the seam points their probes found (to the mm), then the longest, go first. A chain along a
    groove's edge or beside a corner finds the seam too, but a chain on it traces it best, and
    the chains traced later are skipped where they lie inside it (trace.inside_traced)."""
    fitted = [(k, fit) for k, fit in probes.items() if fit.kind is not None]
    offset_mm = np.mean([np.linalg.norm(fit.point_m - chain.points[k]) for k, fit in fitted]) * 1000 if fitted else 0.0
    return (-len(fitted) / max(len(probes), 1), round(offset_mm), -polyline_length(chain.points))
