"""Surface normals by PCA over a radius neighbourhood, oriented toward the camera."""

from __future__ import annotations

import numpy as np
from scipy import sparse

from weldseam.pipeline.neighbours import extreme_eigenvectors, neighbour_covariance


def estimate_normals(points: np.ndarray, graph: sparse.csr_matrix, *, camera_origin_m: np.ndarray) -> np.ndarray:
    """Unit normals (N, 3): eigenvector of the smallest eigenvalue of the covariance of each
    point's neighbours (rows of `graph`, e.g. `radius_graph(points, radius_m)`), flipped so
    that n . (C - p) >= 0 (C = camera origin: (3,), or (N, 3) the camera that saw each point)."""
    return orient_toward(pca_normals(points, graph), points, camera_origin_m)


def pca_normals(points: np.ndarray, graph: sparse.csr_matrix) -> np.ndarray:
    """Unoriented PCA normals (N, 3) over the neighbourhoods given by `graph`."""
    return extreme_eigenvectors(neighbour_covariance(points, graph), largest=False)


def orient_toward(normals: np.ndarray, points: np.ndarray, camera_origin_m: np.ndarray) -> np.ndarray:
    """Flip each normal that points away from the camera origin ((3,) or one per point (N, 3))."""
    facing = np.einsum("ij,ij->i", normals, np.asarray(camera_origin_m) - points)
    return np.where(facing[:, None] < 0, -normals, normals)
