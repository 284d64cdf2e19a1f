"""Segmentation: threshold the descriptor automatically and cluster the seam candidates."""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import connected_components

from weldseam.pipeline.descriptor import gradient_descriptor
from weldseam.pipeline.neighbours import radius_graph
from weldseam.pipeline.normals import pca_normals


def automatic_threshold(
    *, spacing_m: float, normals_radius_m: float, descriptor_radius_m: float, variant: str, min_crease_deg: float
) -> float:
    """The descriptor value on the crease line of an ideal, noiseless crease of
    `min_crease_deg` (two half-planes), sampled at the working spacing and run through the
    same normal and descriptor code as the scan.

    A point passes when its surface bends at least as much as that crease does at its fold,
    so the rule is in physical terms (degrees), independent of noise level, point density
    and the descriptor variant, and needs no tuning per scan.
    """
    half_extent = 3.0 * max(normals_radius_m, descriptor_radius_m)
    ticks = np.arange(-half_extent, half_extent + spacing_m / 2, spacing_m)
    u, v = np.meshgrid(ticks, ticks, indexing="ij")
    bend = np.radians(min_crease_deg)
    height = np.where(u > 0, u * np.tan(bend), 0.0)
    points = np.column_stack([u.ravel(), v.ravel(), height.ravel()])
    normals = pca_normals(points, radius_graph(points, normals_radius_m))
    normals *= np.where(normals[:, 2:3] < 0, -1.0, 1.0)
    values = gradient_descriptor(normals, radius_graph(points, descriptor_radius_m), variant=variant)
    on_fold = (np.abs(points[:, 0]) <= spacing_m / 2) & (np.abs(points[:, 1]) <= half_extent / 3)
    return float(np.median(values[on_fold]))


def cluster_candidates(
    points: np.ndarray, selected: np.ndarray, *, tolerance_m: float, min_length_m: float
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Euclidean clusters of the selected points (indices into `points`): those whose longest
    extent (along their principal axis) reaches `min_length_m`, largest first, and those too
    short (extent at least `tolerance_m`: smaller specks are not candidates at all)."""
    indices = np.flatnonzero(selected)
    if len(indices) == 0:
        return [], []
    _, labels = connected_components(radius_graph(points[indices], tolerance_m), directed=False)
    clusters, short = [], []
    for label in np.unique(labels):
        members = indices[labels == label]
        centred = points[members] - points[members].mean(axis=0)
        axis = np.linalg.svd(centred, full_matrices=False)[2][0] if len(members) > 1 else np.zeros(3)
        extent = np.ptp(centred @ axis) if len(members) > 1 else 0.0
        if extent >= min_length_m:
            clusters.append(members)
        elif extent >= tolerance_m:
            short.append(members)
    return sorted(clusters, key=lambda members: (-len(members), int(members[0]))), short
