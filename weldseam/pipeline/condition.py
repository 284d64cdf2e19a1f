"""Input conditioning: drop invalid points, crop, voxel-merge, remove statistical outliers."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from weldseam.pipeline.grid import voxel_centroids


def condition_points(points: np.ndarray, *, voxel_m: float, crop_min_m=None, crop_max_m=None) -> np.ndarray:
    """Finite (N, 3) metre points inside the crop box, one centroid per `voxel_m` voxel."""
    kept = points[np.isfinite(points).all(axis=1)]
    if crop_min_m is not None:
        kept = kept[(kept >= np.asarray(crop_min_m)).all(axis=1)]
    if crop_max_m is not None:
        kept = kept[(kept <= np.asarray(crop_max_m)).all(axis=1)]
    return voxel_centroids(kept, voxel_m)


def remove_statistical_outliers(points: np.ndarray, *, neighbours: int, std_ratio: float) -> np.ndarray:
    """Drop points whose mean distance to their `neighbours` nearest neighbours exceeds the
    cloud's mean of that distance + std_ratio * its standard deviation (stray returns,
    flying pixels)."""
    if len(points) <= neighbours:
        return points
    distances, _ = cKDTree(points).query(points, neighbours + 1, workers=-1)
    mean_distance = distances[:, 1:].mean(axis=1)
    limit = mean_distance.mean() + std_ratio * mean_distance.std()
    return points[mean_distance <= limit]
