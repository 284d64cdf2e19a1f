"""Thin gaps: the opening of a square butt joint, found in the sensor's own image.

A square butt's gap (0.5-4 mm) between two coplanar plates is narrower than a working voxel and
bends nothing: no descriptor or valley sees it. The sensor does: the pixels looking into the gap
return nothing (a stereo match fails in so narrow a slot) or what lies behind the plates (the
floor through the gap, the table or a fixture far below a mounted pair, the gap's far wall seen
obliquely): a line of pixels, missing or deeper, between two surfaces that carry on at one level.
Binned by direction at half the sensor's angular pitch, in the orientation of its pixel grid
(sensor_grid), a single view's scan is that image again. Along a row or a column, a point lies
behind when its range exceeds the straight line between the points a widest gap's width before
and after it by BEHIND_M and BEHIND_SIGMAS times the sensor's depth noise at its range
(range_noise_m); a run of at least MIN_EMPTY_BINS bins holding no point in front (empty, or
behind) between two points `max_width_m` (plus a pixel's footprint each) apart crosses such a
gap when the two lie on one surface (the line through either and the surface a gap's width
beyond it meets the other: a step down past an edge, a corner's faces, do not) and the run is
open (empty, or its farthest point behind the line between its ends: noise alone is not); the
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
# The floor or far wall seen through an opening lies at least this far behind the surface around it
# (along the line of sight: a plate 3 mm thick, a wall seen from 30 degrees 1.7 mm down).
BEHIND_M = 0.0015
# ... and this many times the sensor's depth noise (range_noise_m): its own ripple is no opening.
BEHIND_SIGMAS = 5.0
# The noise is measured in this many groups of points by range (a stereo sensor's grows with the
# square of it) and interpolated between them.
NOISE_GROUPS = 8
# Every 7th line of the image gives the noise: thousands of points still, and an odd stride takes
# both of the two lines of bins a row of pixels falls on.
NOISE_STRIDE = 7
# A view's bins fill a box a few times its point count; past this many bins per point (an outlier
# at a wide angle) the image is not built.
MAX_BINS_PER_POINT = 16


def gap_midpoints(points: np.ndarray, camera_m: np.ndarray, *, max_width_m: float) -> np.ndarray:
    """(M, 3) middles of the gap crossings in a single view's scan `points` (N, 3, finite) seen
    from `camera_m` (3,): runs of at least MIN_EMPTY_BINS bins in a row or a column of the
    direction image holding no point in front (empty, or _behind), between two points of one
    surface at most max_width_m + 2 pixel footprints apart, the run open (see the module). None
    found (no sensor grid: sensor_grid) gives (0, 3)."""
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
    offsets = points - camera_m
    ranges = np.sqrt(np.einsum("ij,ij->i", offsets, offsets))
    # One point per bin: where two share one (rare at half the pitch), the last written.
    owner = np.full(rows * columns, -1, dtype=np.int32)
    owner[(bins[:, 0] - low[0]) * columns + (bins[:, 1] - low[1])] = np.arange(len(points), dtype=np.int32)
    image = owner.reshape(rows, columns)
    # The widest opening spans this many bins where the nearest points lie.
    nearest_m = np.percentile(ranges[::NOISE_STRIDE], 5)
    reach = int(np.ceil((max_width_m / (pitch_rad * nearest_m) + 1) * BINS_PER_PIXEL))
    sample = image[::NOISE_STRIDE]
    sampled = np.flatnonzero(sample >= 0)
    at, noise = range_noise_m(sampled, ranges[sample.ravel()[sampled]])
    noise_m = np.interp(ranges, at, noise) if len(at) else np.zeros(len(ranges))
    behind_m = np.maximum(BEHIND_M, BEHIND_SIGMAS * noise_m)
    # The columns copied before the rows' pass takes its points behind out of the image.
    return np.vstack([_line_middles(lines, points, ranges, behind_m, reach, max_width_m, pitch_rad)
                      for lines in (np.ascontiguousarray(image.T), image)])


def _line_middles(lines, points, ranges, behind_m, reach, max_width_m, pitch_rad) -> np.ndarray:
    """(M, 3) middles of the crossings along the lines of `lines` (lines, bins; point indices, -1
    empty; changed in place: the points _behind set to -1), their ends at most max_width_m plus
    two pixel footprints at the farther end's range apart, on one surface (_one_surface) over an
    open run (_open)."""
    count = lines.shape[1]
    flat = np.flatnonzero(lines >= 0)
    indices = lines.ravel()[flat]
    line_ranges, line_behind_m = ranges[indices], behind_m[indices]
    behind = _behind(flat, count, line_ranges, reach, line_behind_m)
    lines.ravel()[flat[behind]] = -1
    first, second = _crossings(lines >= 0)
    index_a, index_b = _owner(lines, first), _owner(lines, second)
    range_a, range_b = ranges[index_a], ranges[index_b]
    width = np.linalg.norm(points[index_b] - points[index_a], axis=1)
    narrow = np.flatnonzero(width <= max_width_m + 2 * pitch_rad * np.maximum(range_a, range_b))
    first, second, index_a, index_b = first[narrow], second[narrow], index_a[narrow], index_b[narrow]
    range_a, range_b, tolerance = range_a[narrow], range_b[narrow], behind_m[index_a]
    kept = _one_surface(flat, behind, count, line_ranges, first, second, range_a, range_b, reach, tolerance)
    kept &= _open(flat, count, line_ranges, first, second, range_a, range_b, tolerance)
    return (points[index_a[kept]] + points[index_b[kept]]) / 2


def range_noise_m(flat: np.ndarray, ranges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sensor's depth noise (m) as it grows with range: (ranges, noise) at NOISE_GROUPS
    groups of equal count, by range, of the points at ascending flat positions `flat` (an image's
    lines of bins) with `ranges`, that have a neighbouring pixel on either side in their line:
    1.4826 x the median absolute second difference of range across the three / sqrt(6), the
    standard deviation of one point's range about a smooth surface. Empty arrays where too few."""
    step = np.diff(flat)
    neighbours = np.flatnonzero((step[:-1] == BINS_PER_PIXEL) & (step[1:] == BINS_PER_PIXEL))
    if len(neighbours) < NOISE_GROUPS:
        return np.empty(0), np.empty(0)
    second = np.abs(ranges[neighbours] - 2 * ranges[neighbours + 1] + ranges[neighbours + 2])
    middle = ranges[neighbours + 1]
    groups = np.array_split(np.argsort(middle, kind="stable"), NOISE_GROUPS)
    at = np.array([np.median(middle[group]) for group in groups])
    noise = np.array([1.4826 * np.median(second[group]) / np.sqrt(6) for group in groups])
    return at, noise


def _behind(flat: np.ndarray, count: int, ranges: np.ndarray, reach: int, behind_m: np.ndarray) -> np.ndarray:
    """(K,) bool: which of the points at ascending flat positions `flat` (lines of `count` bins),
    at `ranges` (K,) from the camera, lie over `behind_m` (K,) farther than the straight line, in
    range over bins, between the points reach / BINS_PER_PIXEL pixels before and after them in
    their line: the floor or far wall seen through an opening narrower than that (a step down past
    an edge marks its first pixels too; _one_surface drops the runs they make)."""
    shift = reach // BINS_PER_PIXEL
    behind = np.zeros(len(flat), dtype=bool)
    if len(flat) <= 2 * shift:
        return behind
    line = flat // count
    end = len(flat) - shift
    known = (line[: end - shift] == line[shift:end]) & (line[2 * shift:] == line[shift:end])
    left, right = flat[: end - shift], flat[2 * shift:]
    fraction = (flat[shift:end] - left) / (right - left)
    range_left = ranges[: end - shift]
    expected = range_left + (ranges[2 * shift:] - range_left) * fraction
    behind[shift:end] = known & (ranges[shift:end] > expected + behind_m[shift:end])
    return behind


def _open(flat: np.ndarray, count: int, ranges: np.ndarray, first: np.ndarray, second: np.ndarray,
          range_first: np.ndarray, range_second: np.ndarray, behind_m: np.ndarray) -> np.ndarray:
    """(K,) bool: whether each run from flat position `first` to `second` of lines of `count` bins
    (its ends' ranges range_first, range_second) is open, given every point at ascending flat
    positions `flat` with `ranges`: no point within its bins or the bins above and below them
    (missing pixels, as _crossings counts them), or the farthest of those lies over `behind_m`
    behind the straight line between its ends. A point that noise put behind its neighbours'
    line, in a stretch of surface _behind marked as a whole, is not."""
    runs, entries = [], []
    for shift in (-count, 0, count):
        start = np.searchsorted(flat, first + shift, side="right")
        inside = np.searchsorted(flat, second + shift, side="left") - start
        runs.append(np.repeat(np.arange(len(first)), inside))
        offsets = np.arange(inside.sum()) - np.repeat(np.cumsum(inside) - inside, inside)
        entries.append(offsets + np.repeat(start, inside))
    run, entry = np.concatenate(runs), np.concatenate(entries)
    fraction = ((flat[entry] - first[run]) % count) / (second[run] - first[run])
    excess = ranges[entry] - (range_first[run] + (range_second[run] - range_first[run]) * fraction) - behind_m[run]
    deepest = np.full(len(first), -np.inf)
    np.maximum.at(deepest, run, excess)
    return (np.bincount(run, minlength=len(first)) == 0) | (deepest > 0)


def _one_surface(flat: np.ndarray, behind: np.ndarray, count: int, ranges: np.ndarray, first: np.ndarray,
                 second: np.ndarray, range_first: np.ndarray, range_second: np.ndarray, reach: int,
                 tolerance_m: np.ndarray) -> np.ndarray:
    """(K,) bool: whether each run from flat position `first` to `second` (ranges range_first,
    range_second) joins two points of one surface, given the points at ascending flat positions
    `flat` (lines of `count` bins) with their `ranges` and which lie `behind`: the line through
    the run's end and the point at least `reach` bins beyond it, in range over bins, passes within
    `tolerance_m` of its other end, from either side where such a point in front lies in the line.
    A step down (a lap's edge, a part's silhouette against the table) or a corner's two faces does
    not."""
    line = first // count
    result = np.ones(len(first), dtype=bool)
    before = np.searchsorted(flat, first - reach, side="right") - 1
    after = np.searchsorted(flat, second + reach, side="left")
    for near, far, near_range, far_range, reference in (
        (first, second, range_first, range_second, before), (second, first, range_second, range_first, after)
    ):
        inside = (reference >= 0) & (reference < len(flat))
        reference = np.clip(reference, 0, len(flat) - 1)
        known = inside & (flat[reference] // count == line) & ~behind[reference]
        slope = (near_range - ranges[reference]) / np.where(known, near - flat[reference], 1)
        result &= ~known | (np.abs(near_range + slope * (far - near) - far_range) <= tolerance_m)
    return result


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
