"""Centroid thinning: contract scattered seam points onto their centre line."""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.neighbours import neighbour_mean, pairs_graph, principal_directions, radius_pairs

# Thinning stops once no point moves more than this in an iteration (a hundredth of the fine voxel).
SETTLED_M = 1e-5


def thin_points(point_sets: list[np.ndarray], *, radius_m, iterations: int) -> list[np.ndarray]:
    """Each (N, 3) set of `point_sets` thinned on its own: every point moves toward the centroid
    of its neighbours within `radius_m` (one for all sets, or one per set) in its set, across the
    line only: the step's component
    along the local principal direction is removed, so the points gather on the centre line
    without clumping into blobs along it. Repeated `iterations` times, or until no point of the
    set moves more than SETTLED_M. Points with at most two neighbours at the start are isolated
    noise and dropped.

    The sets (one per seam candidate, often dozens of a few hundred points) are thinned together:
    one neighbourhood graph over all of them, with no edge between sets, and one solve per
    iteration (per set, the fixed cost of twenty small solves would dominate).
    """
    radii = np.broadcast_to(np.asarray(radius_m, np.float64), (len(point_sets),))
    counts = np.diff(_graph(point_sets, radii).indptr) - 1
    kept = np.split(counts > 2, np.cumsum([len(points) for points in point_sets])[:-1])
    thinned = [points[keep] for points, keep in zip(point_sets, kept)]
    moving = [k for k, points in enumerate(thinned) if len(points)]
    for _ in range(iterations):
        if not moving:
            break
        sets = [thinned[k] for k in moving]
        sizes = [len(points) for points in sets]
        points = np.concatenate(sets)
        # Each set about its own mean: the covariances then lose no digits to the sets' distance.
        local = points - np.repeat([one.mean(axis=0) for one in sets], sizes, axis=0)
        graph = _graph(sets, radii[moving])
        step = neighbour_mean(graph, local) - local
        tangent = principal_directions(local, graph)
        move = step - np.sum(step * tangent, axis=1, keepdims=True) * tangent
        starts = np.cumsum([0] + sizes[:-1])
        largest = np.maximum.reduceat(np.abs(move).max(axis=1), starts)
        for k, moved in zip(moving, np.split(points + move, starts[1:])):
            thinned[k] = moved
        moving = [k for k, largest_move in zip(moving, largest) if largest_move > SETTLED_M]
    return thinned


def _graph(point_sets: list[np.ndarray], radii: np.ndarray):
    """pairs_graph over all the sets' points (concatenated), with the pairs within each set only,
    within its radius (radii (S,))."""
    starts = np.cumsum([0] + [len(points) for points in point_sets])
    pairs = [radius_pairs(points, radius) + np.int32(start) for points, start, radius in zip(point_sets, starts, radii)
             if len(points) > 1]  # fmt: skip
    return pairs_graph(np.concatenate(pairs) if pairs else np.empty((0, 2), np.int32), int(starts[-1]))
