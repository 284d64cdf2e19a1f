"""Merge several frames of one workpiece, each already placed in the base frame by its pose.

Each frame is cut into small surface patches (voxels, each with a plane fitted to the points
of the 3 x 3 x 3 voxels around it). Patches seen edge-on are flying-pixel veils at depth
edges and are dropped. Then all frames are registered at once: one point-to-plane ICP moves
every frame but the first (the reference, whose own pose error passes to the result)
against all the others together, so a frame is held by every frame it overlaps, not only by
the earlier ones. It aligns smooth patches only (a groove, an edge or a seam is seen
differently from each side and would bias it), and where the surface bends too sharply for
them, smooth patches of half the size (a groove's flanks, which fix a seam's cross
direction); it takes as many patches of each facing direction (a table filling most of a
view must not outvote the part's few faces that fix the other directions). A motion the
overlaps do not fix (a slide along a prism, a turn about an axis of symmetry) is left as
the poses give it and counted, never guessed; a registration that does not settle changes
no frame and says so.

Where two frames see the two sides of a thin wall (the outside of a pipe, and its inside
through the open top) only one side is kept, the one not enclosed by the part: the seam
stages expect, as in any single view, one surface in a neighbourhood. Last, the frames are
de-duplicated on a voxel grid: in each voxel only the frame with the most points there is
kept (the densest view is the closest, most head-on one), so an overlap holds one surface,
not two noisy layers. Every merged point keeps the camera origin of the frame that saw it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import MergeConfig
from weldseam.geometry import transform_points
from weldseam.pipeline import register
from weldseam.pipeline.neighbours import radius_pairs
from weldseam.pipeline.outline import outline_edges
from weldseam.pipeline.patches import Patches, direction_cells, frame_patches, voxel_keys
from weldseam.pipeline.register import Registration, Surface

PATCHES_PER_DIRECTION = 400  # ICP patches per facing direction (direction_cells) and patch size
FAR_SIDE_M = 0.015  # two frames seeing opposite faces of a wall thinner than this: one face is kept
MAX_WALL_ANGLE_DEG = 60.0  # a wall's two faces are within this of facing opposite ways
CONVEXITY_MARGIN_PER_M = 5.0  # curvatures closer than this (a 200 mm radius) are alike



class MergedFrames(NamedTuple):
    """points_m (N, 3), camera_origins_m (N, 3) of the frame that saw each point, frame (N,)
    int index of that frame; corrections (K, 4, 4): the rigid ICP correction applied to each
    frame on top of its pose (identity for the reference and unrefined frames); overlap (K,):
    share of each frame's ICP patches that found the surface of another frame (1 for the
    reference); refined (K,) bool; converged: the ICP ended with a step below CONVERGED_M
    (when it did not, no frame was refined); undetermined (K,): in how many directions of
    the joint motion that the overlaps leave open (kept as the poses give them) each frame
    moves; far_side (K,): points of each frame dropped as the far side of a thin wall."""

    points_m: np.ndarray
    camera_origins_m: np.ndarray
    frame: np.ndarray
    corrections: np.ndarray
    overlap: np.ndarray
    refined: np.ndarray
    converged: bool
    undetermined: np.ndarray
    far_side: np.ndarray


def merge_frames(frames: Sequence[np.ndarray], camera_origins_m: np.ndarray, params: MergeConfig) -> MergedFrames:
    """Align (joint point-to-plane ICP) and merge base-frame frames (K of (N_k, 3), metres)
    seen from `camera_origins_m` (K, 3).

    `params` (MergeConfig): patches are `icp_voxel_m` voxels; a patch seen more edge-on than `max_incidence_deg`
    (angle between its normal and the ray to the camera) is a veil and its points are
    dropped. ICP pairs each frame's smooth patches with the nearest smooth patch of every
    other frame (normals within register.MAX_NORMAL_ANGLE_DEG), at most `icp_max_distance_m` apart at
    first (the largest pose error it corrects), halving to 2 x `icp_voxel_m`. Each step
    minimises sum a_i w_i r_i^2 over the motions of all frames but the first at once:
    r_i = n_i . (p_i - q_i) the distance of a patch point to the paired patch's plane, a_i
    the patch's area, Tukey weights w_i = (1 - (r_i / c)^2)^2 with c = 4.685 x 1.4826
    median |r| (from 0.5 mm up to the reach). Only directions of the joint motion that the
    pairs fix (register.MIN_FACING_AREA_M2) move. A frame whose share of paired patches is below
    `min_overlap` keeps its pose (refined False) and takes no part. Non-finite points are
    dropped.
    """
    icp_voxel_m, max_incidence_deg = params.icp_voxel_m, params.max_incidence_deg
    origins = np.asarray(camera_origins_m, dtype=np.float64).reshape(-1, 3)
    clouds, patches = [], []
    for cloud, origin in zip(frames, origins):
        cloud = np.asarray(cloud, dtype=np.float64)
        finite = np.isfinite(cloud).all(axis=1)
        cloud = cloud if finite.all() else cloud[finite]
        found = frame_patches(cloud, origin, icp_voxel_m, max_incidence_deg)
        seen = ~found.veil[found.group]
        clouds.append(cloud[seen])
        patches.append(found._replace(group=found.group[seen]))
    count = len(clouds)
    if params.refine and count > 1:
        surfaces = [_icp_surface(cloud, patch, origin, icp_voxel_m, max_incidence_deg)
                    for cloud, patch, origin in zip(clouds, patches, origins)]
        registration = register.register(surfaces, params.icp_max_distance_m, 2.0 * icp_voxel_m, params.min_overlap)
        if registration.undetermined.any():
            edges = [outline_edges(patch, cloud, origin, icp_voxel_m) for patch, cloud, origin in zip(patches, clouds, origins)]
            registration = register.register_open(registration, edges, params.icp_max_distance_m, 2.0 * icp_voxel_m)
    else:
        registration = Registration(np.tile(np.eye(4), (count, 1, 1)), np.ones(count), np.zeros(count, dtype=bool),
                                    True, np.zeros(count, dtype=int))
    corrections = registration.corrections
    placed = [transform_points(corrections[k], cloud) for k, cloud in enumerate(clouds)]
    moved_origins = np.einsum("kij,kj->ki", corrections[:, :3, :3], origins) + corrections[:, :3, 3]
    near = _near_sides(patches, corrections, origins)
    placed = [cloud[near[k][patch.group]] for k, (cloud, patch) in enumerate(zip(placed, patches))]
    far_side = np.array([len(cloud) - int(n[p.group].sum()) for cloud, n, p in zip(clouds, near, patches)])
    keep = _densest_frame_per_voxel(placed, params.dedup_voxel_m)
    frame = np.repeat(np.arange(count), [int(k.sum()) for k in keep])
    points = np.vstack([cloud[k] for cloud, k in zip(placed, keep)]) if placed else np.empty((0, 3))
    return MergedFrames(points, moved_origins[frame], frame, corrections, registration.overlap,
                        registration.refined, registration.converged, registration.undetermined, far_side)


def merge_warnings(merged: MergedFrames, sources: Sequence[str], *, min_overlap: float, refine: bool) -> list[str]:
    """One line per frame whose pose `merge_frames` could not refine, or not in every
    direction (`sources` names the frames)."""
    if not refine or len(sources) < 2:
        return []
    if not merged.converged:
        return [(f"{sources[0]} and the other frames: the poses did not settle under ICP in {register.MAX_ITERATIONS} "
                 f"steps (moving less than {register.CONVERGED_M * 1000:.2f} mm): every frame's pose is used as given")]
    warnings = []
    for name, overlap, refined, open_dof in zip(sources[1:], merged.overlap[1:], merged.refined[1:],
                                                merged.undetermined[1:]):
        if not refined:
            warnings.append(f"{name}: it overlaps the other frames too little to refine its pose ({overlap:.0%} of "
                            f"its surface, merge.min_overlap {min_overlap:.0%}): its pose is used as given")
        elif open_dof:
            warnings.append(f"{name}: its overlap with the other frames leaves its pose open in {open_dof} "
                            f"direction{'s' if open_dof > 1 else ''} (a slide along a prism or a turn about an axis of "
                            "symmetry): along them its pose is used as given")
    return warnings


def _convexity(patches: Patches, rows: np.ndarray) -> np.ndarray:
    """(R,) the most convex curvature (1/m) of the patches `rows` (R,): the larger
    eigenvalue of the shape operator [[A, B], [B, C]] fitted by least squares to the normal
    curvatures toward its neighbour patches,
    k(t) = (n_j - n_i) . t / |t|^2 = A c^2 + 2 B c s + C s^2, t = p_j - p_i in the tangent
    plane, (c, s) its direction there. Positive where the surface bends away from the side
    its normal faces (the outside of a tube), about 0 on a plane."""
    point, normal, neighbours = patches.point[rows], patches.normal[rows], patches.neighbours[rows]
    helper = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    second = np.cross(normal, first)
    lhs, rhs = np.zeros((len(point), 3, 3)), np.zeros((len(point), 3))
    for index in neighbours.T:
        step = patches.point[index] - point
        step -= normal * np.einsum("ij,ij->i", step, normal)[:, None]
        length2 = np.einsum("ij,ij->i", step, step)
        valid = (index >= 0) & (length2 > 0)
        length2[~valid] = 1.0
        curvature = np.einsum("ij,ij->i", patches.normal[index] - normal, step) / length2
        c, s = np.einsum("ij,ij->i", step, first), np.einsum("ij,ij->i", step, second)
        row = np.column_stack([c * c, 2 * c * s, s * s]) / length2[:, None] * valid[:, None]
        lhs += row[:, :, None] * row[:, None, :]
        rhs += row * curvature[:, None]
    lhs += 1e-9 * np.eye(3)  # a patch with too few neighbours gets a flat answer, not a singular one
    a, b, c = np.linalg.solve(lhs, rhs[:, :, None])[:, :, 0].T
    return (a + c) / 2 + np.sqrt(((a - c) / 2) ** 2 + b * b)


def _icp_surface(cloud: np.ndarray, patches: Patches, origin: np.ndarray, voxel_m: float,
                 max_incidence_deg: float) -> Surface:
    """The smooth `voxel_m` patches of a frame, and where they bend (grooves, edges, small
    radii: too sharp for them), the smooth patches of half that size: a groove's flanks, a
    few millimetres wide, are what fixes a seam's cross direction between views."""
    bent = ~patches.smooth[patches.group]
    fine = frame_patches(cloud[bent], origin, voxel_m / 2, max_incidence_deg)
    levels = [(patches, patches.smooth, voxel_m), (fine, fine.smooth, voxel_m / 2)]
    picked = [(found, np.flatnonzero(smooth)[_balanced(found.normal[smooth], PATCHES_PER_DIRECTION)], size)
              for found, smooth, size in levels]
    def stacked(name: str) -> np.ndarray:
        return np.vstack([getattr(found, name)[index] for found, index, _ in picked])

    area = np.concatenate([np.full(len(index), size * size) for _, index, size in picked])
    return Surface(stacked("point"), stacked("plane"), stacked("normal"), area)


def _balanced(normal: np.ndarray, per_direction: int) -> np.ndarray:
    """Indices (ascending) of at most `per_direction` of `normal` (M, 3) per facing direction
    (direction_cells), evenly strided within each."""
    direction = direction_cells(normal)
    order = np.argsort(direction, kind="stable")
    _, start, size = np.unique(direction[order], return_index=True, return_counts=True)
    rank = np.arange(len(order)) - np.repeat(start, size)
    stride = np.repeat(-(-size // per_direction), size)
    return np.sort(order[rank % stride == 0])


def _near_sides(patches: list[Patches], corrections: np.ndarray, origins: np.ndarray) -> list[np.ndarray]:
    """Per frame, (M_k,) bool: its patches that are not the far side of a thin wall. Two
    surface patches of different frames within FAR_SIDE_M, facing opposite ways (within
    MAX_WALL_ANGLE_DEG: one may be a groove's flank) and each behind the other, are the two
    faces of one wall. The far
    side is the less convex one (by more than CONVEXITY_MARGIN_PER_M: the inside of a tube,
    seen through its open end, against its outside), else the one its camera sees at the
    coarser resolution, cos(incidence) / range^2; ties: the later frame."""
    placed = []
    for p, c, origin in zip(patches, corrections, origins):
        surface = np.flatnonzero(p.surface)
        point, normal = transform_points(c, p.point[surface]), p.normal[surface] @ c[:3, :3].T
        rays = transform_points(c, origin[None])[0] - point
        resolution = np.abs(np.einsum("ij,ij->i", normal, rays)) / np.linalg.norm(rays, axis=1) ** 3
        placed.append((surface, point, normal, resolution))
    trees = [cKDTree(point, balanced_tree=False) for _, point, _, _ in placed]
    facings = [np.unique(direction_cells(normal)) for _, _, normal, _ in placed]
    min_cosine = np.cos(np.radians(MAX_WALL_ANGLE_DEG))
    near = []
    for a, (index, point, normal, resolution) in enumerate(placed):
        wall, far = np.zeros(len(point), dtype=bool), np.zeros(len(point))
        for b, (other_index, other, other_normal, other_resolution) in enumerate(placed):
            if a == b or len(other) == 0:
                continue
            # Only where b faces about the other way somewhere can a patch of a be a wall's side.
            asked = np.flatnonzero(np.isin(direction_cells(-normal), _around(facings[b])))
            distance, nearest = trees[b].query(point[asked], distance_upper_bound=FAR_SIDE_M, workers=-1)
            hit = np.isfinite(distance)
            mine, theirs = asked[hit], nearest[hit]
            apart = other[theirs] - point[mine]
            sides = ((np.einsum("ij,ij->i", normal[mine], other_normal[theirs]) < -min_cosine)
                     & (np.einsum("ij,ij->i", apart, normal[mine]) < 0)
                     & (np.einsum("ij,ij->i", apart, other_normal[theirs]) > 0))
            mine, theirs = mine[sides], theirs[sides]
            bend = _convexity(patches[a], index[mine]) - _convexity(patches[b], other_index[theirs])
            alike = np.abs(bend) <= CONVEXITY_MARGIN_PER_M
            coarser = (resolution[mine] < other_resolution[theirs]) | (
                (resolution[mine] == other_resolution[theirs]) & (a > b))
            wall[mine] = True
            far[mine] = np.maximum(far[mine], (bend < -CONVEXITY_MARGIN_PER_M) | (alike & coarser))
        # One patch's call is noisy where the wall has holes or edges (a groove's root gap):
        # each wall patch takes the majority of the calls within FAR_SIDE_M around it.
        on_wall = np.flatnonzero(wall)
        pairs = radius_pairs(point[on_wall], FAR_SIDE_M)
        ends, voters_of = np.concatenate([pairs[:, 0], pairs[:, 1]]), np.concatenate([pairs[:, 1], pairs[:, 0]])
        calls = far[on_wall] + np.bincount(ends, weights=far[on_wall][voters_of], minlength=len(on_wall))
        voters = 1.0 + np.bincount(ends, minlength=len(on_wall))
        keep = np.ones(len(patches[a].point), dtype=bool)
        keep[index[on_wall[calls > 0.5 * voters]]] = False
        near.append(keep)
    return near


def _around(cells: np.ndarray) -> np.ndarray:
    """The direction cells `cells` and those up to two cells away: two unit normals less than
    1 apart in every coordinate (closer than 60 degrees) lie in them."""
    x, y, z = cells // 16, cells // 4 % 4, cells % 4
    span = range(-2, 3)
    shifted = [(x + i, y + j, z + k) for i in span for j in span for k in span]
    return np.unique(np.concatenate([((u * 4 + v) * 4 + w)[(np.minimum(u, np.minimum(v, w)) >= 0)
                                                           & (np.maximum(u, np.maximum(v, w)) <= 3)]
                                     for u, v, w in shifted]))


def _densest_frame_per_voxel(clouds: list[np.ndarray], voxel_m: float) -> list[np.ndarray]:
    """Per cloud, (N_k,) bool: its points in the `voxel_m` voxels (one grid for all) where it
    has the most points of all clouds (ties: the earlier cloud)."""
    if not any(len(cloud) for cloud in clouds):
        return [np.zeros(len(cloud), dtype=bool) for cloud in clouds]
    corner = np.min([cloud.min(axis=0) for cloud in clouds if len(cloud)], axis=0)
    groups = [  # each cloud's own voxels first: sorting N_k keys is cheaper than sorting all at once
        np.unique(voxel_keys(cloud, corner, voxel_m), return_inverse=True, return_counts=True) for cloud in clouds
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
