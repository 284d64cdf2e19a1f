"""Input conditioning: drop invalid points, crop, voxel-merge, remove statistical outliers."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from weldseam.pipeline.grid import voxel_centroids


def condition_points(
    points: np.ndarray,
    *,
    voxel_m: float,
    crop_min_m=None,
    crop_max_m=None,
    outlier_neighbours: int = 8,
    outlier_std_ratio: float = 3.0,
) -> np.ndarray:
    """Clean (N, 3) metre points: finite only, inside the crop box, one centroid per
    `voxel_m` voxel, and without points whose mean distance to their k nearest neighbours
    exceeds mean + outlier_std_ratio * std of that distance over the cloud."""
    kept = points[np.isfinite(points).all(axis=1)]
    if crop_min_m is not None:
        kept = kept[(kept >= np.asarray(crop_min_m)).all(axis=1)]
    if crop_max_m is not None:
        kept = kept[(kept <= np.asarray(crop_max_m)).all(axis=1)]
    kept = voxel_centroids(kept, voxel_m)
    if len(kept) <= outlier_neighbours:
        return kept
    distances, _ = cKDTree(kept).query(kept, outlier_neighbours + 1, workers=-1)
    mean_distance = distances[:, 1:].mean(axis=1)
    limit = mean_distance.mean() + outlier_std_ratio * mean_distance.std()
    return kept[mean_distance <= limit]
