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


def camera_origins(scan, working: np.ndarray, warnings: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(camera, working_camera): the scan's camera origin ((3,), or (N, 3) one per scan point for
    merged frames) and the one that saw each working point ((3,) or (M, 3)). Without a camera
    origin a camera above the part is assumed (1 m over the centroid along +z), and `warnings`
    says so."""
    from weldseam.errors import InputError

    if scan.camera_origin_m is None:
        finite = scan.points_m[np.isfinite(scan.points_m).all(axis=1)]
        camera = (finite.mean(axis=0) if len(finite) else np.zeros(3)) + np.array([0.0, 0.0, 1.0])
        warnings.append("no camera origin given: normals oriented toward +z (a camera above the part)")
    else:
        camera = np.asarray(scan.camera_origin_m, dtype=np.float64)
    if camera.shape not in ((3,), scan.points_m.shape):
        raise InputError(f"{scan.source}: camera_origin_m must be (3,) or one (3,) per point, got {camera.shape}")
    if camera.ndim == 1:
        return camera, camera
    return camera, _nearest_origins(scan.points_m, camera, working)


def camera_record(camera: np.ndarray) -> list:
    """The camera origin(s) for the run's record, to the nanometre: one (3,) list, or the distinct
    origins of merged frames in order (runs of equal rows collapsed)."""
    if camera.ndim == 1:
        return [round(float(v), 9) for v in camera]
    changes = np.r_[True, np.any(camera[1:] != camera[:-1], axis=1)]
    return np.round(camera[changes], 9).tolist()


# Scan points searched for the camera that saw each working point.
ORIGIN_SAMPLE = 200_000


def _nearest_origins(points: np.ndarray, origins: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """(Q, 3) camera origin of the scan point nearest each query, among an even subsample of at
    most ORIGIN_SAMPLE finite points (merged frames own whole 3 mm voxels, so a point ~1 mm
    away belongs to a camera that saw the same surface; any such camera orients it)."""
    from scipy.spatial import cKDTree

    finite = np.flatnonzero(np.isfinite(points).all(axis=1))
    finite = finite[:: max(1, -(-len(finite) // ORIGIN_SAMPLE))]
    tree = cKDTree(points[finite], balanced_tree=False, compact_nodes=False)
    return origins[finite[tree.query(queries, workers=-1)[1]]]
