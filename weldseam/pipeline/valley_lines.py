"""Valleys along their length: the fine valley depth averaged along each point's valley direction.

Between two tubes or curved plates meeting at 120-160 degrees, rounded at the bottom, the valley
depth over descriptor.radius_m is as small as a sensor's noise (0.25-0.37 mm, median, on the
broad valleys the fine pass misses, against noise floors of 0.40-0.69 mm), and over the wide pass's
20 mm the tubes' own bend cancels it (0.07 mm). Along the valley it stays, and noise averages out:
the mean over a line `length_m` long through each point, along the valley, is 0.15-0.33 mm at
those seams and under 0.12 mm at nine points in ten elsewhere (0.02-0.05 mm at half of them).

The direction along a valley is the one in which the surface bends least: the normal x the
direction in which the normals around the point spread most (their covariance's largest
eigenvector over DIRECTION_RADIUS_M, on a grid COARSE_M wide: the valley, not each point's noise,
sets it). The line's samples lie one working spacing apart; each takes the valley depth of the
working point in its voxel (none where the surface is not there). The sensor's ripple makes lines
too: its troughs run straight across a plate or the table; sections refuse those (no two faces
meet there) as they refuse any crease that is no joint.
"""

from __future__ import annotations

import numpy as np

from weldseam.geometry import column_bounds, principal_extent, unit
from weldseam.pipeline.grid import voxel_grid
from weldseam.pipeline.neighbours import extreme_eigenvectors, neighbour_covariance, radius_graph

# The normals' spread is taken over this radius, on voxels this wide: a valley between tubes turns
# its normals by 20-60 degrees across 10-20 mm; a point's own neighbourhood is noise.
DIRECTION_RADIUS_M = 0.012
COARSE_M = 0.008
# A line is averaged only where at least this share of its samples find the surface.
MIN_SAMPLE_SHARE = 0.5
# A valley's band (its points whose mean depth shows it) is a line: 4-15 mm wide on average on the
# broad valleys' seams (band_width_m), where the sensor's ripple, its troughs side by side, makes
# areas 19-47 mm wide on the speed frames' plates. Bands wider than this many descriptor radii are none.
MAX_BAND_WIDTH_RADII = 3.0
# Normals whose covariance's trace is no more than this (rounding) do not spread: a plane.
FLAT_SPREAD = 1e-12


def line_valley_depth(points: np.ndarray, normals: np.ndarray, depth: np.ndarray, *, spacing_m: float,
                      length_m: float) -> np.ndarray:
    """(N,) mean valley `depth` (N,) over the points (N, 3, about one per `spacing_m` voxel: the
    working cloud) met by a line through each point along its valley (valley_directions), sampled
    every `spacing_m` out to ceil(length_m / 2 / spacing_m) samples either side, each sample the
    depth of the first point in the voxel (of a grid from the points' own corner) it falls in;
    none where the surface is not there. Averaged only at points of positive depth (a valley's
    line passes through them; the others take 0) that bend somewhere, and where MIN_SAMPLE_SHARE
    of the samples meet a point."""
    mean = np.zeros(len(points))
    if len(points) == 0:
        return mean
    along = valley_directions(points, normals)
    sought = np.flatnonzero((depth > 0) & np.any(along != 0, axis=1))
    if len(sought) == 0:
        return mean
    reach = int(np.ceil(length_m / 2 / spacing_m))
    # Voxel coordinates from a corner `reach` voxels beyond the points (every sample falls inside),
    # each voxel's key a float searched among the points' own: exact while the box holds under
    # 2^53 voxels (a 10 m scan at 2.5 mm holds ~1e10).
    origin = column_bounds(points)[0] - (reach + 1) * spacing_m
    cells = np.floor((points - origin) / spacing_m)
    extent = column_bounds(cells)[1] + reach + 2
    strides = np.array([extent[1] * extent[2], extent[2], 1.0])
    keys, first = np.unique(cells @ strides, return_index=True)
    keys = np.append(keys, np.inf)  # a sample beyond the last key finds this one, and no point
    key_depth = np.append(depth[first], 0.0)
    start = (points[sought] - origin) / spacing_m
    along = along[sought]
    total = np.zeros(len(sought))
    found = np.zeros(len(sought), dtype=np.int64)
    for step in range(-reach, reach + 1):
        key = np.floor(start + step * along) @ strides
        slot = np.searchsorted(keys, key)
        hit = keys[slot] == key
        total += np.where(hit, key_depth[slot], 0.0)
        found += hit
    mean[sought] = np.where(found >= MIN_SAMPLE_SHARE * (2 * reach + 1), total / np.maximum(found, 1), 0.0)
    return mean


def valley_directions(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(N, 3) unit direction along the valley (or ridge) at each point: its COARSE_M voxel's mean
    normal x the largest eigenvector of the covariance of the voxels' normals within
    DIRECTION_RADIUS_M (the direction the surface bends in); 0 where those normals do not spread
    at all (a plane without noise bends nowhere, in any frame)."""
    coarse, voxel = voxel_grid(points, COARSE_M)
    coarse_normals = unit(np.column_stack([np.bincount(voxel, column, len(coarse)) for column in normals.T]))
    covariance = neighbour_covariance(coarse_normals, radius_graph(coarse, DIRECTION_RADIUS_M))
    along = unit(np.cross(coarse_normals, extreme_eigenvectors(covariance, largest=True)))
    along[covariance[:, :3].sum(axis=1) <= FLAT_SPREAD] = 0.0
    return along[voxel]


def band_width_m(points: np.ndarray, spacing_m: float) -> float:
    """Mean width (m) of a band of points (K, 3), one per `spacing_m` voxel: its area K spacing^2
    over its length (its extent along its principal axis)."""
    return len(points) * spacing_m**2 / max(principal_extent(points), spacing_m)
