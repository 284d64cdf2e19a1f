"""Thin gaps: the opening of a square butt joint, found in the sensor's own image.

A square butt's gap (0.5-4 mm) between two coplanar plates is narrower than a working voxel and
bends nothing: no descriptor or valley sees it. The sensor does: the pixels looking into the gap
often return nothing (a stereo match fails in so narrow a slot), a line of missing pixels between
two surfaces that carry on at one level. (Where they return the floor seen through the gap, the
valleys find it.) Binned by direction at half the sensor's angular pitch, in the orientation of
its pixel grid (sensor_grid), a single view's scan is that image again: a run of at least
MIN_EMPTY_BINS empty bins between two points of a row or a column, the points within
`max_width_m` (plus a pixel's footprint each) of each other, crosses such a gap, and the
middle of the two points lies in it. A round dropout gives such crossings too, but no line of
them as long as a seam (the clustering drops it).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from weldseam.geometry import column_bounds, unit

# Bins per sensor pixel: a row's consecutive pixels lie two bins apart, one empty bin between them
# (two where the measured pitch or angle is a little off across the image), and a missing pixel
# leaves three or more.
BINS_PER_PIXEL = 2
# A run of this many empty bins is a crossing: a pixel or more missing in a row.
MIN_EMPTY_BINS = 3
# Points (nearest the middle of the view) whose neighbour spacing gives the pitch and the grid.
GRID_SAMPLE = 5_000
# A sensor's pixels, seen as directions, lie on a square grid: the angles of the vectors to
# their nearest neighbours cluster at four right angles, |mean(exp(4 i phi))| near 1 (0.75-1.0 on
# the D415 frames here, real and simulated). Below this the cloud is no image (0.48 on a lidar's
# scan of a tee; a resampled or merged cloud).
MIN_GRID_ORDER = 0.5
MIN_POINTS = 1000
# A view's bins fill a box a few times its point count; past this many bins per point (an outlier
# at a wide angle) the image is not built.
MAX_BINS_PER_POINT = 16


def gap_midpoints(points: np.ndarray, camera_m: np.ndarray, *, max_width_m: float) -> np.ndarray:
    """(M, 3) middles of the gap crossings in a single view's scan `points` (N, 3, finite) seen
    from `camera_m` (3,): empty runs of at least MIN_EMPTY_BINS bins in a row or a column of the
    direction image, between points at most max_width_m + 2 pixel footprints apart. None found
    (no sensor grid: sensor_grid) gives (0, 3)."""
    if len(points) < MIN_POINTS:
        return np.empty((0, 3))
    directions = image_directions(points, camera_m)
    grid = sensor_grid(directions)
    if grid is None:
        return np.empty((0, 3))
    pitch_rad, angle_rad = grid
    cos, sin = np.cos(angle_rad), np.sin(angle_rad)
    aligned = directions @ np.array([[cos, -sin], [sin, cos]])
    bins = np.floor(aligned * (BINS_PER_PIXEL / pitch_rad)).astype(np.int64)
    low, high = column_bounds(bins)
    rows, columns = (high - low + 1).tolist()
    if rows * columns > MAX_BINS_PER_POINT * len(points):
        return np.empty((0, 3))
    # One point per bin: where two share one (rare at half the pitch), the last written.
    owner = np.full(rows * columns, -1, dtype=np.int32)
    owner[(bins[:, 0] - low[0]) * columns + (bins[:, 1] - low[1])] = np.arange(len(points), dtype=np.int32)
    image = owner.reshape(rows, columns)
    filled = image >= 0
    middles = []
    for lines, occupied in ((image, filled), (image.T, np.ascontiguousarray(filled.T))):
        first, second = _crossings(occupied)
        ends_a, ends_b = points[_owner(lines, first)], points[_owner(lines, second)]
        ranges = np.maximum(np.linalg.norm(ends_a - camera_m, axis=1), np.linalg.norm(ends_b - camera_m, axis=1))
        footprint = pitch_rad * ranges
        width = np.linalg.norm(ends_b - ends_a, axis=1)
        narrow = width <= max_width_m + 2 * footprint
        middles.append((ends_a[narrow] + ends_b[narrow]) / 2)
    return np.vstack(middles)


def _crossings(filled: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(first, second) flat positions of the ends of each run of at least MIN_EMPTY_BINS empty bins
    within a line of the image whose `filled` (lines, bins) bool says which bins hold a point. A bin
    counts as filled where the bin above or below it is (a pixel that noise in its direction put
    into the next line of bins fills no line's run with a false gap: a run is empty in three lines
    at once), while a gap, a line across the lines, leaves all three empty."""
    near = filled.copy()
    near[1:] |= filled[:-1]
    near[:-1] |= filled[1:]
    positions = np.flatnonzero(near)
    length = filled.shape[1]
    first, second = positions[:-1], positions[1:]
    crossing = (first // length == second // length) & (second - first - 1 >= MIN_EMPTY_BINS)
    return first[crossing], second[crossing]


def _owner(lines: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """The point index at flat positions of the image `lines` (-1 where empty): the bin's own, else
    the bin above's, else the bin below's (as _crossings counts them filled)."""
    row, column = np.divmod(flat, lines.shape[1])
    own = lines[row, column]
    above = np.where(row > 0, lines[np.maximum(row - 1, 0), column], -1)
    below = np.where(row < lines.shape[0] - 1, lines[np.minimum(row + 1, lines.shape[0] - 1), column], -1)
    return np.where(own >= 0, own, np.where(above >= 0, above, below))


def image_directions(points: np.ndarray, camera_m: np.ndarray) -> np.ndarray:
    """(N, 2) tangent-plane coordinates (x / z, y / z) of `points` (N, 3) seen from `camera_m` in a
    frame whose z is their mean direction from it: a pinhole sensor's pixel grid, seen along its
    own axis (column by column: geometry.column_bounds says why)."""
    z = unit(np.array([column.mean() for column in points.T]) - camera_m)
    x = unit(np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z))
    frame = np.stack([x, np.cross(z, x), z])
    local = points @ frame.T - frame @ camera_m
    return local[:, :2] / local[:, 2:3]


def sensor_grid(directions: np.ndarray) -> tuple[float, float] | None:
    """(pitch, angle) of the pixel grid in `directions` (N, 2): the median distance from each of
    the GRID_SAMPLE points nearest the median direction to its nearest neighbour, and the grid's
    orientation arg(mean(exp(4 i phi))) / 4 of the neighbour vectors' angles phi; None where those
    angles do not cluster at right angles (order under MIN_GRID_ORDER)."""
    low, high = column_bounds(directions)
    centre = (low + high) / 2
    # A square about the middle holding GRID_SAMPLE points were they spread evenly over the box.
    half = 0.5 * np.sqrt(np.prod(high - low) * min(GRID_SAMPLE / len(directions), 1.0))
    offsets = np.abs(directions - centre)
    inside = np.flatnonzero((offsets[:, 0] <= half) & (offsets[:, 1] <= half))
    if len(inside) < MIN_POINTS:
        return None
    sample = directions[inside]
    spacing, neighbour = cKDTree(sample).query(sample, k=2)
    vectors = sample[neighbour[:, 1]] - sample
    phi = np.arctan2(vectors[:, 1], vectors[:, 0])
    mean = complex(np.mean(np.cos(4 * phi)), np.mean(np.sin(4 * phi)))
    if abs(mean) < MIN_GRID_ORDER:
        return None
    return float(np.median(spacing[:, 1])), float(np.angle(mean) / 4)
