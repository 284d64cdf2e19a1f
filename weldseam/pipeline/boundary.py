"""Boundary extraction: the rim points of a seam band."""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.neighbours import centroid_offsets, radius_graph


def boundary_mask(points: np.ndarray, normals: np.ndarray, *, radius_m: float, shift_ratio: float) -> np.ndarray:
    """True where a point lies on the rim of the region: the centroid of its neighbours
    within `radius_m`, projected on the tangent plane, is more than shift_ratio * radius_m
    away from it (inside a region it is ~0; on a straight rim it is 4r/(3 pi) ~ 0.42 r).
    Holes narrower than about radius/3 do not shift the centroid enough to count."""
    shift = inward_shift(centroid_offsets(radius_graph(points, radius_m), points), normals)
    return np.linalg.norm(shift, axis=1) > shift_ratio * radius_m


def inward_shift(offsets: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(N, 3) offset of each point's neighbour centroid (`offsets`, neighbours.centroid_offsets)
    in its tangent plane: ~0 inside a surface, pointing into the surface at its rim."""
    return offsets - np.sum(offsets * normals, axis=1, keepdims=True) * normals
