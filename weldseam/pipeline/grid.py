"""Voxel grid: merge points that fall in one cubic cell into their centroid."""

from __future__ import annotations

import numpy as np

from weldseam.geometry import column_bounds
from weldseam.pipeline.parallel import row_blocks, run_parts


def voxel_centroids(points: np.ndarray, leaf_m: float) -> np.ndarray:
    """Centroids (M, 3) of the points in each occupied voxel of edge `leaf_m`.

    Voxel keys are computed from the cloud's own minimum corner, so the output order
    (ascending voxel key) is deterministic for a given input. The keys are cut into ranges
    handled on both cores (parallel.run_parts); each voxel's sum runs over its points
    in input order either way, so the result does not depend on the cut.
    """
    if len(points) == 0:
        return points.copy()
    keys = _voxel_keys(points, leaf_m)
    blocks = row_blocks(len(points))
    if len(blocks) == 1:
        return _centroids(points, keys)
    # Key ranges holding about as many points as the row blocks (from a sample of the keys).
    sample = np.sort(keys[:: max(1, len(keys) // 1000)])
    bounds = [sample[len(sample) * block.start // len(points)] for block in blocks[1:]]
    ranges = np.searchsorted(bounds, keys, side="right")

    def in_range(index: int) -> np.ndarray:
        chosen = ranges == index
        return _centroids(points[chosen], keys[chosen])

    return np.concatenate(run_parts(in_range, range(len(blocks))))


def voxel_grid(points: np.ndarray, leaf_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(centroids, index): voxel_centroids(points, leaf_m) and the index (N,) of each point's
    voxel among them, from one sort of the keys (on one core; each voxel's sum runs over its
    points in input order, as in voxel_centroids, so the centroids are the same to the bit)."""
    if len(points) == 0:
        return points.copy(), np.empty(0, np.intp)
    _, inverse, counts = np.unique(_voxel_keys(points, leaf_m), return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    return _voxel_means(points, inverse, counts), inverse


def _voxel_keys(points: np.ndarray, leaf_m: float) -> np.ndarray:
    """(N,) int64 key of each point's voxel of edge `leaf_m`, from the cloud's minimum corner."""
    cells = np.floor((points - column_bounds(points)[0]) / leaf_m).astype(np.int64)
    extent = column_bounds(cells)[1] + 1
    return (cells[:, 0] * extent[1] + cells[:, 1]) * extent[2] + cells[:, 2]


def _centroids(points: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Centroid of the points sharing each key, in ascending key order."""
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return _voxel_means(points, inverse, counts)


def _voxel_means(points: np.ndarray, inverse: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Mean (M, 3) of the points in each voxel (`inverse` (N,) their voxel, `counts` (M,)), each
    summed in input order."""
    sums = np.column_stack([np.bincount(inverse, weights=points[:, k], minlength=len(counts)) for k in range(3)])
    return sums / counts[:, None]
