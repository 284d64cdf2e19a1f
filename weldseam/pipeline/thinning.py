"""Centroid thinning: contract scattered seam points onto their centre line."""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.neighbours import neighbour_mean, principal_directions, radius_graph

# Thinning stops once no point moves more than this in an iteration (a hundredth of the fine voxel).
SETTLED_M = 1e-5


def thin_points(points: np.ndarray, *, radius_m: float, iterations: int) -> np.ndarray:
    """Move every point toward the centroid of its neighbours within `radius_m`, across the
    line only: the step's component along the local principal direction is removed, so the
    points gather on the centre line without clumping into blobs along it. Repeated
    `iterations` times, or until no point moves more than SETTLED_M. Points with at most two
    neighbours at the start are isolated noise and dropped."""
    counts = np.diff(radius_graph(points, radius_m).indptr) - 1
    thinned = points[counts > 2]
    for _ in range(iterations):
        if len(thinned) == 0:
            break
        graph = radius_graph(thinned, radius_m)
        step = neighbour_mean(graph, thinned) - thinned
        tangent = principal_directions(thinned, graph)
        move = step - np.sum(step * tangent, axis=1, keepdims=True) * tangent
        thinned = thinned + move
        if np.max(np.abs(move)) <= SETTLED_M:
            break
    return thinned
