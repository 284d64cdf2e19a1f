"""Merge several frames of one workpiece, each already placed in the base frame by its pose.

Each frame first loses its flying-pixel veils (patches seen edge-on). The first frame is the
reference: every other frame, in order, is refined by point-to-plane ICP against the union of
the frames before it (so a frame only needs to overlap one earlier frame); ICP fixes the frames
relative to the reference, whose own pose error passes to the result. Then the frames are
de-duplicated on a voxel grid: in each voxel only the frame with the most points there is kept
(the densest view is the closest, most head-on one), so an overlap holds one surface, not two
noisy layers. Every merged point keeps the camera origin of the frame that saw it.

ICP needs overlaps that fix all six degrees of freedom: two views sharing only parallel faces
(a prism) cannot be placed along it, and a surface of revolution cannot be turned about its
axis (harmless for a seam around that axis).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from weldseam.geometry import transform_points
from weldseam.pipeline.neighbours import COVARIANCE_ENTRIES, extreme_eigenvectors

COARSE_ITERATIONS = 20
FINE_ITERATIONS = 20
MAX_ICP_POINTS = 3000  # source points per ICP iteration (evenly strided): plenty for 6 unknowns
TUKEY_C = 4.685  # Tukey's biweight constant, in robust standard deviations (1.4826 MAD)
MIN_SCALE_M = 0.0005  # the Tukey cut-off never drops below this (sensor noise scale)
CONVERGED_M = 3e-5  # an ICP step moving every point by less than this ends the pass
NEIGHBOURS = 10  # samples in the PCA of an ICP normal
PATCH_RADIUS_VOXELS = 2.5  # ...all within this many voxels: a surface patch, not stray points
# ICP uses planar patches only: lambda_min / trace of the neighbourhood covariance below this
# (a noisy plane ~0.01). Flying-pixel veils at depth edges differ between views and would bias it.
MAX_SURFACE_VARIATION = 0.01
MAX_NORMAL_ANGLE_DEG = 20.0


class MergedFrames(NamedTuple):
    """points_m (N, 3), camera_origins_m (N, 3) of the frame that saw each point, frame (N,)
    int index of that frame; corrections (K, 4, 4): the rigid ICP correction applied to each
    frame on top of its pose (identity for the reference and unrefined frames); overlap (K,):
    share of each frame's ICP points that found the surface of the earlier frames (1 for the
    reference); refined (K,) bool."""

    points_m: np.ndarray
    camera_origins_m: np.ndarray
    frame: np.ndarray
    corrections: np.ndarray
    overlap: np.ndarray
    refined: np.ndarray


def merge_frames(
    frames: Sequence[np.ndarray], camera_origins_m: np.ndarray, *, dedup_voxel_m: float, icp_voxel_m: float,
    icp_max_distance_m: float, min_overlap: float, max_incidence_deg: float, refine: bool = True,
) -> MergedFrames:
    """Align (point-to-plane ICP) and merge base-frame frames (K of (N_k, 3), metres) seen from
    `camera_origins_m` (K, 3).

    Each frame is first cut to its surface: on `icp_voxel_m` voxel centroids, a patch seen
    more edge-on than `max_incidence_deg` (angle between its PCA normal and the ray to the
    camera) is a veil of flying pixels at a depth edge, harmless in its own frame (sparse) but
    not beside another frame's dense view of the face behind it; its points are dropped.
    ICP pairs planar centroids: a first pass up to `icp_max_distance_m` apart (the largest
    pose error it corrects), a second up to 2 x `icp_voxel_m`, each minimising sum w_i r_i^2,
    r_i = n_i . (R p_i + t - q_i), with Tukey weights w_i = (1 - (r_i / c)^2)^2,
    c = 4.685 x 1.4826 median |r| (0.5 mm to the pass's distance). A frame whose share of
    paired points is below `min_overlap` keeps its pose (refined False). Non-finite points
    are dropped.
    """
    origins = np.asarray(camera_origins_m, dtype=np.float64).reshape(-1, 3)
    clouds, samples, normals = [], [], []
    for cloud, origin in zip(frames, origins):
        cloud = np.asarray(cloud, dtype=np.float64)
        finite = np.isfinite(cloud).all(axis=1)
        cloud = cloud if finite.all() else cloud[finite]
        surface, sample, sample_normals = _surface(cloud, origin, icp_voxel_m, max_incidence_deg)
        clouds.append(cloud[surface])
        samples.append(sample)
        normals.append(sample_normals)
    count = len(clouds)
    corrections = np.tile(np.eye(4), (count, 1, 1))
    overlap, refined = np.ones(count), np.zeros(count, dtype=bool)
    if refine and count > 1:
        fine_m = 2.0 * icp_voxel_m
        for k in range(1, count):
            correction, overlap[k] = _point_to_plane_icp(
                samples[k], normals[k], *_placed_union(samples, normals, corrections, range(k)),
                ((icp_max_distance_m, COARSE_ITERATIONS), (fine_m, FINE_ITERATIONS)),
            )
            refined[k] = overlap[k] >= min_overlap
            if refined[k]:
                corrections[k] = correction
    placed = [transform_points(corrections[k], cloud) if refined[k] else cloud for k, cloud in enumerate(clouds)]
    moved_origins = np.einsum("kij,kj->ki", corrections[:, :3, :3], origins) + corrections[:, :3, 3]
    keep = _densest_frame_per_voxel(placed, dedup_voxel_m)
    frame = np.repeat(np.arange(count), [int(k.sum()) for k in keep])
    points = np.vstack([cloud[k] for cloud, k in zip(placed, keep)]) if placed else np.empty((0, 3))
    return MergedFrames(points, moved_origins[frame], frame, corrections, overlap, refined)


def _surface(cloud: np.ndarray, origin: np.ndarray, voxel_m: float, max_incidence_deg: float):
    """(N,) bool: points of `cloud` not in an edge-on patch (a veil); and the planar `voxel_m`
    centroids with their unit PCA normals (over the NEIGHBOURS nearest centroids, turned
    toward the camera at `origin`), (M, 3) each, for ICP."""
    if len(cloud) == 0:
        return np.zeros(0, dtype=bool), cloud, cloud
    _, group, sizes = np.unique(_voxel_keys(cloud, cloud.min(axis=0), voxel_m), return_inverse=True,
                                return_counts=True)
    group = group.ravel()
    sample = np.column_stack([np.bincount(group, weights=cloud[:, k]) for k in range(3)]) / sizes[:, None]
    if len(sample) <= NEIGHBOURS:
        return np.ones(len(cloud), dtype=bool), sample[:0], sample[:0]
    distance, nearest = cKDTree(sample, balanced_tree=False).query(sample, k=NEIGHBOURS, workers=-1)
    neighbours = sample[nearest]
    centred = neighbours - neighbours.mean(axis=1, keepdims=True)
    x, y, z = centred[..., 0], centred[..., 1], centred[..., 2]
    xy, xz, yz = (x * y).mean(axis=1), (x * z).mean(axis=1), (y * z).mean(axis=1)
    covariance = np.stack(
        [(x * x).mean(axis=1), xy, xz, xy, (y * y).mean(axis=1), yz, xz, yz, (z * z).mean(axis=1)], axis=1
    ).reshape(-1, 3, 3)
    rows, cols = np.array(COVARIANCE_ENTRIES).T
    normals = extreme_eigenvectors(covariance[:, rows, cols], largest=False)
    rays = origin - sample
    facing = np.einsum("ij,ij->i", normals, rays)
    normals = np.where(facing[:, None] < 0, -normals, normals)
    cosine = np.abs(facing) / np.linalg.norm(rays, axis=1)
    patch = distance[:, -1] <= PATCH_RADIUS_VOXELS * voxel_m
    veil = patch & (cosine < np.cos(np.radians(max_incidence_deg)))
    flatness = np.einsum("ni,nij,nj->n", normals, covariance, normals)
    planar = patch & ~veil & (flatness <= MAX_SURFACE_VARIATION * np.trace(covariance, axis1=1, axis2=2))
    return ~veil[group], sample[planar], normals[planar]


def _placed_union(samples, normals, corrections, frames) -> tuple[np.ndarray, np.ndarray]:
    """The ICP centroids (M, 3) and normals (M, 3) of `frames`, each moved by its correction."""
    return (
        np.vstack([transform_points(corrections[j], samples[j]) for j in frames]),
        np.vstack([normals[j] @ corrections[j][:3, :3].T for j in frames]),
    )


def _point_to_plane_icp(source, source_normals, target, target_normals, passes):
    """(4, 4) correction moving `source` (N, 3) onto the surface `target` (M, 3), and the share
    of source points paired in the last iteration (0 when too few pair: no correction).
    `passes`: (pairing distance m, at most this many iterations) pairs, run in order. A pair
    is two points within the pass's distance whose normals (each toward its own camera) agree
    within MAX_NORMAL_ANGLE_DEG: a point whose own surface the target lacks (hidden, or at
    grazing incidence in the other view) must not pull toward a neighbouring face, nor the
    outside of a wall toward its inside seen by another view."""
    min_cosine = np.cos(np.radians(MAX_NORMAL_ANGLE_DEG))
    stride = max(1, -(-len(source) // MAX_ICP_POINTS))
    if len(source) == 0 or len(target) == 0:
        return np.eye(4), 0.0
    tree = cKDTree(target, balanced_tree=False)
    matrix = np.eye(4)
    paired = 0.0
    for index, (reach, iterations) in enumerate(passes):
        # Early passes only bring the frame close: a third of the points will do.
        thin = stride if index == len(passes) - 1 else 3 * stride
        points, point_normals = source[::thin], source_normals[::thin]
        for _ in range(iterations):
            moved = transform_points(matrix, points)
            distance, nearest = tree.query(moved, distance_upper_bound=reach, workers=-1)
            found = np.isfinite(distance)
            found[found] = np.einsum(
                "ij,ij->i", point_normals[found] @ matrix[:3, :3].T, target_normals[nearest[found]]
            ) >= min_cosine
            paired = float(found.mean())
            if found.sum() < 6:
                return np.eye(4), 0.0
            p, q, n = moved[found], target[nearest[found]], target_normals[nearest[found]]
            residual = np.einsum("ij,ij->i", n, p - q)
            scale = min(reach, max(TUKEY_C * 1.4826 * np.median(np.abs(residual)), MIN_SCALE_M))
            weight = np.clip(1.0 - (residual / scale) ** 2, 0.0, None) ** 2
            centre = p.mean(axis=0)
            jacobian = np.hstack([np.cross(p - centre, n), n])
            step = np.linalg.lstsq(
                jacobian.T @ (weight[:, None] * jacobian), -jacobian.T @ (weight * residual), rcond=None
            )[0]
            update = _small_motion(step[:3], step[3:], centre)
            matrix = update @ matrix
            if np.linalg.norm(step[:3]) * np.abs(p - centre).max() + np.linalg.norm(step[3:]) < CONVERGED_M:
                break
    return matrix, paired


def _small_motion(rotation_vector: np.ndarray, translation: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(4, 4) rotation R = exp([w]x) about `centre` followed by `translation`: p -> R (p - c) + c + t."""
    from scipy.spatial.transform import Rotation

    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_rotvec(rotation_vector).as_matrix()
    matrix[:3, 3] = centre - matrix[:3, :3] @ centre + translation
    return matrix


def _densest_frame_per_voxel(clouds: list[np.ndarray], voxel_m: float) -> list[np.ndarray]:
    """Per cloud, (N_k,) bool: its points in the `voxel_m` voxels (one grid for all) where it
    has the most points of all clouds (ties: the earlier cloud)."""
    if not any(len(cloud) for cloud in clouds):
        return [np.zeros(len(cloud), dtype=bool) for cloud in clouds]
    corner = np.min([cloud.min(axis=0) for cloud in clouds if len(cloud)], axis=0)
    groups = [  # each cloud's own voxels first: sorting N_k keys is cheaper than sorting all at once
        np.unique(_voxel_keys(cloud, corner, voxel_m), return_inverse=True, return_counts=True) for cloud in clouds
    ]
    voxel = np.concatenate([g[0] for g in groups])
    size = np.concatenate([g[2] for g in groups])
    cloud_of = np.repeat(np.arange(len(clouds)), [len(g[0]) for g in groups])
    order = np.lexsort((cloud_of, -size, voxel))
    first = np.r_[True, voxel[order][1:] != voxel[order][:-1]]
    winner = np.zeros(len(voxel), dtype=bool)
    winner[order[first]] = True
    offsets = np.r_[0, np.cumsum([len(g[0]) for g in groups])]
    return [winner[offsets[k] + g[1].ravel()] for k, g in enumerate(groups)]


def _voxel_keys(points: np.ndarray, corner: np.ndarray, voxel_m: float) -> np.ndarray:
    """(N,) int64 key of the `voxel_m` voxel of each point (N, 3) of a grid anchored at `corner`
    (3,), no point below it: x, y, z cell indices below 2^21 each (8.4 km at 4 mm)."""
    cells = ((points - corner) * (1.0 / voxel_m)).astype(np.int64)  # truncation is floor here
    return (cells[:, 0] << 42) | (cells[:, 1] << 21) | cells[:, 2]
