"""Voxel grid: merge points that fall in one cubic cell into their centroid."""

from __future__ import annotations

import numpy as np


def voxel_centroids(points: np.ndarray, leaf_m: float) -> np.ndarray:
    """Centroids (M, 3) of the points in each occupied voxel of edge `leaf_m`.

    Voxel keys are computed from the cloud's own minimum corner, so the output order
    (ascending voxel key) is deterministic for a given input.
    """
    if len(points) == 0:
        return points.copy()
    cells = np.floor((points - points.min(axis=0)) / leaf_m).astype(np.int64)
    extent = cells.max(axis=0) + 1
    keys = (cells[:, 0] * extent[1] + cells[:, 1]) * extent[2] + cells[:, 2]
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    sums = np.column_stack([np.bincount(inverse, weights=points[:, k]) for k in range(3)])
    return sums / counts[:, None]
