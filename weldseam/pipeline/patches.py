"""Patches: a frame cut into small surface patches, one per voxel, each with its plane.

A patch's plane is fitted to the points of the 3 x 3 x 3 voxels around it; patches seen more
edge-on than the incidence limit are flying-pixel veils at depth edges; a smooth patch's normal
turns little to its neighbours'. Registration (merge, register) and the outline of a frame's
faces (outline) work on them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from weldseam.pipeline.neighbours import COVARIANCE_ENTRIES, extreme_eigenvectors

# A patch has at least this many occupied voxels of the 27 around it (fewer are stray points);
# a surface patch, at least this many points in each on average (sparser: flying pixels).
MIN_PATCH_VOXELS = 6
MIN_POINTS_PER_VOXEL = 2.0
# A smooth patch's normal is within this of each neighbour patch's (a 30 mm radius turns 8 deg in 4 mm).
MAX_PATCH_TURN_DEG = 15.0
# Key differences (see voxel_keys) to the 27 voxels around one, itself included.
NEIGHBOUR_KEYS = np.array([(i << 42) + (j << 21) + k for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])


class Patches(NamedTuple):
    """One frame's surface patches (M of them): group (N,) patch of each point; point (M, 3)
    voxel centroid projected on the patch plane; plane (M, 3) a point of that plane (the
    mean of the 3 x 3 x 3 voxels around); normal (M, 3) unit, toward the camera; count (M,)
    points in the voxel; veil (M,) seen more edge-on than the incidence limit; surface (M,)
    neither a veil nor stray points; smooth (M,) a surface patch whose normal turns little
    to its neighbours'; neighbours (M, 27) the patches around each (-1: none)."""

    group: np.ndarray
    point: np.ndarray
    plane: np.ndarray
    normal: np.ndarray
    count: np.ndarray
    veil: np.ndarray
    surface: np.ndarray
    smooth: np.ndarray
    neighbours: np.ndarray


def frame_patches(cloud: np.ndarray, origin: np.ndarray, voxel_m: float, max_incidence_deg: float) -> Patches:
    """The `voxel_m` patches of `cloud` (N, 3) seen from `origin` (3,). Each patch's plane is
    fitted to the points of the 3 x 3 x 3 voxels around it (covariance from summed moments):
    voxel centroids alone lie off the plane where noise splits a surface between two layers
    of voxels, and would pull ICP by a fraction of the noise."""
    if len(cloud) == 0:
        empty = np.zeros((0, 3))
        none = np.zeros(0, dtype=bool)
        return Patches(np.zeros(0, dtype=np.intp), empty, empty, empty, np.zeros(0), none, none, none,
                       np.zeros((0, len(NEIGHBOUR_KEYS)), dtype=np.intp))
    corner = cloud.min(axis=0) - voxel_m  # every voxel has its neighbours' cell indices >= 0
    keys, group, counts = np.unique(voxel_keys(cloud, corner, voxel_m), return_inverse=True, return_counts=True)
    group = group.ravel()
    centre = cloud.mean(axis=0)
    x, y, z = (cloud - centre).T
    moments = np.column_stack([counts] + [
        np.bincount(group, weights=v, minlength=len(keys)) for v in (x, y, z, x * x, y * y, z * z, x * y, x * z, y * z)
    ])
    # Row -1 of the padded moments is zero: a missing neighbour adds nothing.
    padded = np.vstack([moments, np.zeros((1, moments.shape[1]))])
    neighbours = neighbour_voxels(keys)
    block = np.zeros_like(moments)
    for index in neighbours.T:
        block += padded[index]
    mean = block[:, 1:4] / block[:, :1]
    first, second = np.array(COVARIANCE_ENTRIES).T
    covariance = block[:, 4:] / block[:, :1] - mean[:, first] * mean[:, second]
    normal = extreme_eigenvectors(covariance, largest=False)
    plane = mean + centre
    centroid = moments[:, 1:4] / moments[:, :1] + centre
    point = centroid - normal * np.einsum("ij,ij->i", normal, centroid - plane)[:, None]
    rays = origin - point
    facing = np.einsum("ij,ij->i", normal, rays)
    normal = np.where(facing[:, None] < 0, -normal, normal)
    occupied = (neighbours >= 0).sum(axis=1)
    patch = occupied >= MIN_PATCH_VOXELS
    veil = patch & (np.abs(facing) < np.cos(np.radians(max_incidence_deg)) * np.linalg.norm(rays, axis=1))
    surface = patch & ~veil & (block[:, 0] >= MIN_POINTS_PER_VOXEL * occupied)
    smooth = surface.copy()
    rows = np.flatnonzero(surface)
    turn = np.einsum("ij,ikj->ik", normal[rows], np.vstack([normal, normal[:1]])[neighbours[rows]])
    smooth[rows] = np.all((turn >= np.cos(np.radians(MAX_PATCH_TURN_DEG))) | (neighbours[rows] < 0), axis=1)
    return Patches(group, point, plane, normal, counts.astype(np.float64), veil, surface, smooth, neighbours)


def neighbour_voxels(keys: np.ndarray) -> np.ndarray:
    """(V, 27) index into the sorted unique voxel keys `keys` (V,) of the voxels around each
    (NEIGHBOUR_KEYS order), -1 where there is none. One search per column of 3 voxels along
    z: in sorted keys, z - 1 and z + 1 sit right before and after the key of z."""
    found = np.empty((len(keys), len(NEIGHBOUR_KEYS)), dtype=np.intp)
    padded = np.r_[keys, -1]  # a position past the end reads a key that is never wanted
    for column in range(0, len(NEIGHBOUR_KEYS), 3):
        middle = keys + NEIGHBOUR_KEYS[column + 1]
        at = np.searchsorted(keys, middle)
        here = padded[at] == middle
        below = at - 1
        found[:, column] = np.where((below >= 0) & (padded[below] == middle - 1), below, -1)
        found[:, column + 1] = np.where(here, at, -1)
        above = at + here
        found[:, column + 2] = np.where(padded[above] == middle + 1, above, -1)
    return found


def voxel_keys(points: np.ndarray, corner: np.ndarray, voxel_m: float) -> np.ndarray:
    """(N,) int64 key of the `voxel_m` voxel of each point (N, 3) of a grid anchored at `corner`
    (3,), no point below it: x, y, z cell indices below 2^21 each (8.4 km at 4 mm)."""
    cells = ((points - corner) * (1.0 / voxel_m)).astype(np.int64)  # truncation is floor here
    return (cells[:, 0] << 42) | (cells[:, 1] << 21) | cells[:, 2]


def direction_cells(normals: np.ndarray) -> np.ndarray:
    """(M,) facing direction of each unit normal (M, 3): its cell in a 4 x 4 x 4 grid over [-1, 1]^3."""
    cell = np.minimum(((normals + 1.0) * 2.0).astype(np.int64), 3)
    return (cell[:, 0] * 4 + cell[:, 1]) * 4 + cell[:, 2]
