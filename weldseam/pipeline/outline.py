"""Outline: where a frame's faces end at a real edge of the part, as every view would see it.

A face ends at a crease (another face turns away there) or at the near side of a depth jump
(past its edge the camera sees a farther surface). Both are places on the part, the same
from any view that sees the face, unlike the far side of a jump (where the part's shadow
starts: it moves with the camera), a dropout or the image border. Registration uses them
for what planes cannot fix: a box's top slides along its length unseen by any plane that two
views share, but its ends are edges that both see.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from weldseam.geometry import unit
from weldseam.pipeline.patches import Patches
from weldseam.pipeline.register import Surface

NEAR_NEIGHBOURS = 12  # patches of the first, cheap look around each (about two voxels)
FACE_NEIGHBOURS = 40  # patches searched for the face around a candidate (up to FACE_REACH_VOXELS)
FACE_REACH_VOXELS = 8.0
PLANE_TOLERANCE_VOXELS = 0.5  # a neighbour within this of a patch's plane lies on its face
MIN_FACE_PATCHES = 12  # a patch with fewer face neighbours is clutter, a sliver or a flying pixel
# The mean of the unit directions to a patch's face neighbours, in its plane: about 0 inside a
# face, 2 / pi = 0.64 on a straight edge; past this the patch is at the face's end.
MIN_ONE_SIDEDNESS = 0.45
CREASE_NEIGHBOURS, CREASE_REACH_VOXELS = 64, 5.0  # smooth patches looked at for a crease
MIN_CREASE_DEG = 30.0  # two faces turned by more than this meet at a crease
ADOPTED, ADOPT_VOXELS = 6, 3.0  # smooth patches whose planes a patch may take (_face_normals)
LAST_POINTS, LAST_POINT_TOLERANCE_M = 64, 0.0003  # raw points that place a jump edge (_last_points)
JUMP_VOXELS = 1.5  # a surface this much nearer (farther) along the ray past the edge: occluded (behind)


class _Face(NamedTuple):
    """The face around some patches (R of them, K neighbours each): found (R, K) a neighbour
    there, on_face (R, K) it lies on the patch's plane, in_plane (R, K, 3) its offset in that plane."""

    found: np.ndarray
    on_face: np.ndarray
    in_plane: np.ndarray


def outline_edges(patches: Patches, cloud: np.ndarray, origin: np.ndarray, voxel_m: float) -> Surface:
    """The edge samples of a frame, `cloud` (N, 3) and its surface `patches` (of `voxel_m`
    voxels), seen from `origin` (3,), at most one per voxel and outward octant: point = plane =
    where the face ends along its outward direction o (in the face's plane, across the edge),
    normal = o, area_m2 = voxel_m^2. A sample's ICP residual o . (p - q) is how far one view's
    edge lies past the other's."""
    rows = np.flatnonzero(patches.surface)
    points = patches.point[rows]
    if len(points) <= FACE_NEIGHBOURS or not patches.smooth.any():
        return Surface(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
    normals = _face_normals(points, patches.normal[rows], patches.smooth[rows], voxel_m)
    creases = _crease_samples(points, patches.normal[rows], patches.smooth[rows], voxel_m)
    jumps = _jump_samples(points, normals, origin, voxel_m)
    jumps = (_last_points(_cloud_near(cloud, patches, jumps[0], voxel_m), *jumps, voxel_m), jumps[1])
    end, outward = (np.vstack([creases[k], jumps[k]]) for k in (0, 1))
    keep = _first_per_voxel(end, outward, voxel_m)
    return Surface(end[keep], end[keep], outward[keep], np.full(len(keep), voxel_m * voxel_m))


def _crease_samples(points: np.ndarray, normals: np.ndarray, smooth: np.ndarray,
                    voxel_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Where two smooth faces meet: for each smooth patch p (normal n) and each smooth patch q
    (normal m) within CREASE_REACH_VOXELS turned more than MIN_CREASE_DEG from it and straight
    across the crease line n x m from it (within a voxel along that line), the point of
    p's plane on the crease line, p + t o with o = (n x m) x n toward q and t = m . (q - p) / (m . o),
    and o: (M, 3) points and (M, 3) outward directions. Each face's own plane places the
    crease, not the patches that straddle it (their planes are fitted across it). Only smooth
    patches that far from a patch that is not smooth are looked at: a crease bends the patches
    fitted across it, the inside of a face has none."""
    reach_m = CREASE_REACH_VOXELS * voxel_m
    if smooth.all() or not smooth.any():
        return np.zeros((0, 3)), np.zeros((0, 3))
    normals, bent = normals[smooth], points[~smooth]
    points = points[smooth]
    looked = np.flatnonzero(np.isfinite(cKDTree(bent).query(points, distance_upper_bound=reach_m)[0]))
    distance, index = cKDTree(points).query(points[looked], CREASE_NEIGHBOURS + 1, distance_upper_bound=reach_m)
    found = np.isfinite(distance[:, 1:])
    first = np.repeat(looked, found.sum(axis=1))
    second = index[:, 1:][found]
    n, m = normals[first], normals[second]
    turned = np.einsum("ij,ij->i", n, m) < np.cos(np.radians(MIN_CREASE_DEG))
    first, second, n, m = first[turned], second[turned], n[turned], m[turned]
    line = unit(np.cross(n, m))
    outward = np.cross(line, n)
    toward = points[second] - points[first]
    outward *= np.sign(np.einsum("ij,ij->i", outward, toward))[:, None]
    reach = np.einsum("ij,ij->i", m, toward) / np.einsum("ij,ij->i", m, outward)
    beside = np.abs(np.einsum("ij,ij->i", line, toward)) <= voxel_m  # q faces p across the crease, not past its end
    near = beside & (reach > -0.5 * voxel_m) & (reach < reach_m)
    return points[first[near]] + reach[near, None] * outward[near], outward[near]


def _jump_samples(points: np.ndarray, normals: np.ndarray, origin: np.ndarray, voxel_m: float):
    """Where a face ends at the near side of a depth jump: a patch whose face neighbours all lie
    to one side (MIN_ONE_SIDEDNESS), with no other surface just past its face's last patch along
    the outward direction o and a farther one seen through the gap (JUMP_VOXELS): (M, 3) that
    last patch's point, (M, 3) o and (M, 3) the face's normal."""
    tree = cKDTree(points)
    near = _face_around(tree, points, normals, np.arange(len(points)), NEAR_NEIGHBOURS, voxel_m)
    looked = np.flatnonzero(_one_sidedness(near) >= MIN_ONE_SIDEDNESS / 2)
    face = _face_around(tree, points, normals, looked, FACE_NEIGHBOURS, voxel_m)
    count, mean = face.on_face.sum(axis=1), _mean_direction(face)
    edge = (count >= MIN_FACE_PATCHES) & (np.linalg.norm(mean, axis=1) >= MIN_ONE_SIDEDNESS)
    outward = -unit(np.where(edge[:, None], mean, [[1.0, 0.0, 0.0]]))
    along = np.einsum("nkj,nj->nk", face.in_plane, outward)
    reach = np.where(face.on_face, along, 0.0).max(axis=1)
    end = points[looked] + np.maximum(reach, 0.0)[:, None] * outward
    crease = (face.found & ~face.on_face & (along > reach[:, None])).any(axis=1)
    occluded, behind = _past_edge(points, origin, end + JUMP_VOXELS * voxel_m * outward, voxel_m)
    jump = edge & ~crease & ~occluded & behind
    return end[jump], outward[jump], normals[looked[jump]]


def _cloud_near(cloud: np.ndarray, patches: Patches, ends: np.ndarray, voxel_m: float) -> np.ndarray:
    """The points of `cloud` in the patches within two voxels of any of `ends` (M, 3): all that
    _last_points reads, without a search tree over the whole frame."""
    if len(ends) == 0:
        return cloud[:0]
    near = np.isfinite(cKDTree(ends).query(patches.point, distance_upper_bound=2 * voxel_m)[0])
    return cloud[near[patches.group]]


def _last_points(cloud: np.ndarray, ends: np.ndarray, outward: np.ndarray, normals: np.ndarray,
                 voxel_m: float) -> np.ndarray:
    """(M, 3) each of `ends` moved along its `outward` direction to the farthest point of
    `cloud` near it (LAST_POINTS within a voxel) on its face's plane (`normals`, within
    LAST_POINT_TOLERANCE_M): a patch's point is its voxel's centroid, up to half a voxel
    short of the face's last point, by however the edge cuts the voxel."""
    if len(ends) == 0:
        return ends
    distance, index = cKDTree(cloud).query(ends, LAST_POINTS, distance_upper_bound=voxel_m)
    found = np.isfinite(distance)
    offset = cloud[np.where(found, index, 0)] - ends[:, None, :]
    on_plane = found & (np.abs(np.einsum("nkj,nj->nk", offset, normals)) <= LAST_POINT_TOLERANCE_M)
    beyond = np.where(on_plane, np.einsum("nkj,nj->nk", offset, outward), 0.0).max(axis=1)
    return ends + np.maximum(beyond, 0.0)[:, None] * outward


def _face_normals(points: np.ndarray, normals: np.ndarray, smooth: np.ndarray, voxel_m: float) -> np.ndarray:
    """(N, 3) each patch's normal, or where a smooth patch within ADOPT_VOXELS has a plane that
    the patch lies on (within PLANE_TOLERANCE_VOXELS), that one's: a patch's plane is fitted over
    three voxels, so beside a crease it leans toward the other face; the face's own plane does not."""
    smooth_rows = np.flatnonzero(smooth)
    distance, index = cKDTree(points[smooth_rows]).query(points, ADOPTED, distance_upper_bound=ADOPT_VOXELS * voxel_m)
    found = np.isfinite(distance)
    index = smooth_rows[np.where(found, index, 0)]
    height = np.abs(np.einsum("nkj,nkj->nk", points[:, None, :] - points[index], normals[index]))
    height = np.where(found, height, np.inf)
    best = np.argmin(height, axis=1)
    on_plane = height[np.arange(len(points)), best] <= PLANE_TOLERANCE_VOXELS * voxel_m
    adopted = normals[index[np.arange(len(points)), best]]
    return np.where((on_plane & ~smooth)[:, None], adopted, normals)


def _face_around(tree: cKDTree, points: np.ndarray, normals: np.ndarray, rows: np.ndarray, neighbours: int,
                 voxel_m: float) -> _Face:
    """The `neighbours` nearest patches (within FACE_REACH_VOXELS) of the patches `rows` and
    which of them lie on each one's plane (within PLANE_TOLERANCE_VOXELS)."""
    distance, index = tree.query(points[rows], neighbours + 1, distance_upper_bound=FACE_REACH_VOXELS * voxel_m)
    found = np.isfinite(distance[:, 1:])
    index = np.where(found, index[:, 1:], 0)
    offset = points[index] - points[rows][:, None, :]
    height = np.einsum("nkj,nj->nk", offset, normals[rows])
    in_plane = offset - height[:, :, None] * normals[rows][:, None, :]
    return _Face(found, found & (np.abs(height) <= PLANE_TOLERANCE_VOXELS * voxel_m), in_plane)


def _mean_direction(face: _Face) -> np.ndarray:
    """(R, 3) the mean of the unit in-plane directions to each patch's face neighbours."""
    length = np.linalg.norm(face.in_plane, axis=2)
    directions = np.where(face.on_face[:, :, None], face.in_plane / np.maximum(length, 1e-12)[:, :, None], 0.0)
    return directions.sum(axis=1) / np.maximum(face.on_face.sum(axis=1), 1)[:, None]


def _one_sidedness(face: _Face) -> np.ndarray:
    """(R,) |mean direction to the face neighbours|: 0 inside a face, 2 / pi on a straight edge."""
    return np.linalg.norm(_mean_direction(face), axis=1)


def _past_edge(points: np.ndarray, origin: np.ndarray, beyond: np.ndarray, voxel_m: float):
    """(M,) bool each: the camera's ray to `beyond` (M, 3) meets a surface of `points` more than
    JUMP_VOXELS voxels nearer (the edge is the far side of a jump: a shadow's border), or more
    than that farther (the near side of a jump: a surface is seen past the edge)."""
    rays = points - origin
    ranges = np.linalg.norm(rays, axis=1)
    tree = cKDTree(rays / ranges[:, None])
    target = beyond - origin
    target_range = np.linalg.norm(target, axis=1)
    angle = voxel_m / np.median(ranges)
    distance, index = tree.query(target / target_range[:, None], 8, distance_upper_bound=angle)
    seen = np.isfinite(distance)
    along = ranges[np.where(seen, index, 0)]
    gap = JUMP_VOXELS * voxel_m
    nearer = (seen & (along < target_range[:, None] - gap)).any(axis=1)
    farther = (seen & (along > target_range[:, None] + gap)).any(axis=1)
    return nearer, farther


def _first_per_voxel(points: np.ndarray, outward: np.ndarray, voxel_m: float) -> np.ndarray:
    """Indices (ascending) of the first of `points` (M, 3) in each `voxel_m` voxel per outward
    direction (its octant: the two faces of a crease are two samples)."""
    if len(points) == 0:
        return np.zeros(0, dtype=np.intp)
    keys = np.floor((points - points.min(axis=0)) / voxel_m).astype(np.int64)
    octant = (outward > 0) @ np.array([1, 2, 4])
    _, first = np.unique(np.column_stack([keys, octant]), axis=0, return_index=True)
    return np.sort(first)
