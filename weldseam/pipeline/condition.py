"""Input conditioning: drop invalid points, crop, voxel-merge, find isolated points."""

from __future__ import annotations

import numpy as np

from weldseam.geometry import finite_rows
from weldseam.pipeline.grid import voxel_centroids


def valid_points(points: np.ndarray, *, crop_min_m=None, crop_max_m=None) -> np.ndarray:
    """The finite rows of (N, 3) metre points inside the crop box, in their order."""
    kept = finite_rows(points)
    if crop_min_m is not None:
        kept &= (points >= np.asarray(crop_min_m)).all(axis=1)
    if crop_max_m is not None:
        kept &= (points <= np.asarray(crop_max_m)).all(axis=1)
    # take with the row numbers: a third of the time of indexing (N, 3) rows with the mask.
    return points.take(np.flatnonzero(kept), axis=0)


def condition_points(points: np.ndarray, *, voxel_m: float, crop_min_m=None, crop_max_m=None) -> np.ndarray:
    """Finite (N, 3) metre points inside the crop box (valid_points), one centroid per `voxel_m` voxel."""
    return voxel_centroids(valid_points(points, crop_min_m=crop_min_m, crop_max_m=crop_max_m), voxel_m)


def sparse_points(pairs: np.ndarray, count: int, *, min_fraction: float) -> np.ndarray:
    """True for the points (of `count`) with fewer neighbours (in `pairs`, (M, 2) point indices
    within a radius, each pair once) than `min_fraction` of the median count: stray returns
    and the thin veils of flying pixels at depth edges."""
    neighbours = np.bincount(pairs.ravel(), minlength=count) + 1
    return neighbours < min_fraction * np.median(neighbours)
