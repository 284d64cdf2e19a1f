"""Midpoint pairing: pair each band rim point with the rim point across the band."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from weldseam.pipeline.neighbours import neighbour_mean, principal_directions, radius_graph


def rim_tangents(rim: np.ndarray, radius_m: float) -> np.ndarray:
    """Unit edge tangents (N, 3): principal direction of the rim points within `radius_m`."""
    return principal_directions(rim, radius_graph(rim, radius_m))


def pair_midpoints(
    rim: np.ndarray,
    *,
    tangent_radius_m: float,
    angle_tolerance_deg: float,
    max_width_m: float,
    width_tolerance: float,
    in_band: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints (M, 3) and widths (M,) of rim pairs across the band.

    The partner of rim point b is the nearest rim point q with (q - b) at 90 +- tolerance
    degrees to b's edge tangent and |q - b| <= max_width_m. Pairs whose width differs from
    the typical width of the pairs around them (midpoints within max_width_m / 2; a mean
    taken twice, the second time without the pairs the first one flagged) by more than
    width_tolerance (a fraction) are dropped: at the band's end caps the rim turns and
    pairs there are short or long, which made the reference implementation zig-zag. The
    median is local because one band can join strips of different widths (a groove meeting
    the plate's end edges).

    in_band(points (K, 3)) -> (K,) bool says whether the surface nearest each point belongs to
    the band. A pair must span the band, not a gap: the points 1/4, 1/2 and 3/4 of the way
    across must all be in the band. Without this, where a groove band and a plate-edge band
    merged into one cluster, rims facing each other across the flat strip between them paired
    up and put the "seam" on that strip.
    """
    if len(rim) < 4:
        return np.empty((0, 3)), np.empty(0)
    tangents = rim_tangents(rim, tangent_radius_m)
    first, second = cKDTree(rim).query_pairs(max_width_m, output_type="ndarray").T
    # The tests are symmetric in the two points, so each unordered pair is tested once, one
    # coordinate at a time (1D gathers are ~3x faster than gathering rows of three), and the
    # pairs that pass are then taken both ways round.
    delta = [rim[:, k].take(second) - rim[:, k].take(first) for k in range(3)]
    length = np.sqrt(delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2])
    across = length > 2 * tangent_radius_m
    # Perpendicular to both points' tangents, so both ends agree the pair spans the band.
    for end in (first, second):
        along = delta[0] * tangents[:, 0].take(end) + delta[1] * tangents[:, 1].take(end)
        along += delta[2] * tangents[:, 2].take(end)
        across &= np.abs(along) / np.maximum(length, 1e-12) <= np.sin(np.radians(angle_tolerance_deg))
    first, second, length = first[across], second[across], length[across]
    rows, cols, length = np.concatenate([first, second]), np.concatenate([second, first]), np.concatenate([length] * 2)
    if len(rows) == 0:
        return np.empty((0, 3)), np.empty(0)
    # Each rim point's candidates, nearest first; its partner is the first that spans the band.
    order = np.lexsort((length, rows))
    rows, cols, length = rows[order], cols[order], length[order]
    starts = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
    partner = starts if in_band is None else _first_spanning(rim, rows, cols, starts, in_band)
    rows, cols, length = rows[partner], cols[partner], length[partner]
    if len(rows) == 0:
        return np.empty((0, 3)), np.empty(0)
    midpoints = (rim[rows] + rim[cols]) / 2
    around = radius_graph(midpoints, max_width_m / 2)
    typical = neighbour_mean(around, length)
    inliers = (np.abs(length - typical) <= width_tolerance * typical).astype(float)
    typical = (around @ (length * inliers)) / np.maximum(around @ inliers, 1.0)
    consistent = np.abs(length - typical) <= width_tolerance * typical
    return midpoints[consistent], length[consistent]


def _first_spanning(rim, rows, cols, starts, in_band) -> np.ndarray:
    """Per run of candidate pairs (rows[starts[k]:starts[k + 1]] all the same rim point, nearest
    first), the index of the first pair whose points 1/4, 1/2 and 3/4 of the way across are all
    in the band; runs with none are left out. Only the candidates up to a partner are tested:
    1, 2, 4, ... more per run and round (in_band costs a nearest-neighbour search per point)."""
    ends = np.r_[starts[1:], len(rows)]
    fractions = np.array([0.25, 0.5, 0.75])[:, None, None]
    found = np.full(len(starts), -1)
    pending, tested, batch = np.arange(len(starts)), np.zeros(len(starts), dtype=np.int64), 1
    while len(pending):
        index = starts[pending, None] + tested[pending, None] + np.arange(batch)
        valid = index < ends[pending, None]
        candidates = index[valid]
        first, second = rim[rows[candidates]], rim[cols[candidates]]
        samples = first[None] + fractions * (second - first)[None]
        spans = np.zeros(index.shape, dtype=bool)
        spans[valid] = in_band(samples.reshape(-1, 3)).reshape(len(fractions), -1).all(axis=0)
        hit = spans.any(axis=1)
        found[pending[hit]] = index[hit, np.argmax(spans[hit], axis=1)]
        tested[pending] += batch
        pending = pending[~hit & (starts[pending] + tested[pending] < ends[pending])]
        batch *= 2
    return found[found >= 0]
