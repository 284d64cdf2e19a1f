"""The lap model: a plate lying on another, the seam in the inside corner at the top plate's edge.

Seen from above, the top plate's edge face is often grazing and unseen: the profile is the bottom
plate's surface, a step up of the top plate's thickness, and the top plate's surface. Two
parallel lines (one slope, two intercepts) are fitted left and right of a break (the break
minimising the total squared error); the higher one is the top plate. In plate coordinates
(s along the plates, t out of them) the edge is where the top plate's surface ends, s_e (the
camera sees a surface right up to its edge; where the bottom plate is seen up to the edge too,
the middle of the two ends); the edge face is square to the plates, so the corner is (s_e, t_bottom).
The torch axis aims into the corner at joints.lap_torch_split_deg from the bottom plate:
axis = -(cos(split) e + sin(split) n), e the edge face's outward normal (along the plates, toward
the bottom plate's open side), n the bottom plate's normal; 45 degrees is the bisector.
The bottom plate runs on under the top plate: seen by a single camera, it may end short of the
edge only where the edge hides it (its shadow), and SEEN_GAP_M more; a longer stretch the camera
would have seen, empty, lies between two parts' faces stepped beside each other (a fixture's face
proud beside a block's), which is no lap.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit
from weldseam.pipeline.joints.profile import SortedProfile
from weldseam.pipeline.joints.robust import fraction, line, mean, median, noise

KIND = JointKind.LAP
# Where the step lies does not depend on where the window sits.
CENTRED = False
# A top plate's edge runs the plate's length between its corners; a shorter step is something lying
# on the plate: a clamp's arm (20-30 mm wide, reaching 12-25 mm onto it, its outline turning round
# its end: split.straight_length_m) or a bar's end.
MIN_LENGTH_M = 0.05
SPECIALISES = None
# Thinnest and thickest top plate (m, 2-6 mm with the noise of its measure): a step under 1.5 mm
# is 1 mm depth quantisation or ripple; a taller one is a wall, a plate's edge on the table or a
# clamp's arm (6-10 mm thick).
MIN_STEP_M = 0.0015
MAX_STEP_M = 0.007
# The step must stand this many times the surfaces' noise above it.
MIN_STEP_SIGMAS = 2.0
# Each plate's surface runs at least MIN_PLATE_M out from the corner, straight (MIN_INLIER_FRACTION
# of its side's points on its line). A dropout may hide the rest of either plate (the bottom one's
# beyond the corner as often as the top one's beyond its edge), and the two lines are fitted
# parallel: the longer one gives the slope, and a few mm of the other fix its level. Two surfaces
# both LONG_SURFACE_M long lie within MAX_SKEW_DEG of parallel (a shorter one's own slope says
# little), and the plates are free of a groove over that much beside the step (_dips).
MIN_PLATE_M = 0.005
LONG_SURFACE_M = 0.010
MIN_INLIER_FRACTION = 0.7
MAX_SKEW_DEG = 10.0
# A surface is only as long as the stretch its points fill with gaps of at most this.
MAX_SURFACE_SPACING_M = 0.002
# The bottom plate's surface ending this far short of the top plate's edge is shadowed there:
# the edge is where the top plate ends, not the middle of the gap.
SHADOW_GAP_M = 0.0015
# The bottom plate runs on under the top plate: with a single camera, it may end short of the top
# plate's edge only within the shadow the edge casts (_shadow), and this much more. A longer empty
# stretch the camera would have seen is a gap between two parts' faces, stepped (a fixture's face
# beside a block's, 2-3 mm proud: 7.6-9 mm seen empty, where laps of seeds 0-5 end 0-0.8 mm short).
SEEN_GAP_M = 0.003
# A plate is flat: its surface bows from its line by no more than this, beyond BOW_SIGMAS times
# the bow's own uncertainty. Two crowns of a curved part beside a shallow valley, fitted by two
# parallel lines, pass for a lap's plates stepped 2-2.5 mm (they bow 1.1-1.4 mm over 25 mm, median;
# a lap's plates 0.1-0.4 mm in the same noise).
MAX_BOW_M = 0.0005
BOW_SIGMAS = 3.0
# The fewest points a surface is fitted to.
MIN_SIDE_POINTS = 5
# A plate with more than this share of its points near the step below its line has a groove
# beside the step (_dips).
DEPRESSION_FRACTION = 0.15
# A surface's points lie within 3 sigma of its line, or within this: depth quantised in 1 mm steps
# puts one surface on two levels 1 mm apart.
SURFACE_BAND_M = 0.0012
# How often the two parallel lines are refitted to each other's inliers.
PARALLEL_ROUNDS = 2


class _Plates(NamedTuple):
    """Two parallel lines y = left_y0 + slope x and right_y0 + slope x through the points left and
    right of a break: each side's points (x, y) and which of them lie on its line, and the robust
    noise about the lines."""

    slope: float
    left: tuple[np.ndarray, np.ndarray, np.ndarray]
    right: tuple[np.ndarray, np.ndarray, np.ndarray]
    left_y0: float
    right_y0: float
    sigma: float


def fit(profile: SortedProfile) -> ProfileFit | NoFit:
    """The lap's inside corner in a profile, or why there is none."""
    u, w, params = profile.u, profile.w, profile.params
    first = _parallel_surfaces(u, w)
    if isinstance(first, NoFit):
        return first
    # Seen obliquely, the top plate's surface near its edge lies beside the bottom plate's in u:
    # the step is found again along the plates (s, t = along, out of them), a clean break there.
    along = np.array([1.0, first.slope]) / np.hypot(1.0, first.slope)
    normal = np.array([-along[1], along[0]])
    s, t = u * along[0] + w * along[1], u * normal[0] + w * normal[1]
    order = np.argsort(s)
    plates = _parallel_surfaces(s[order], t[order])
    if isinstance(plates, NoFit):
        return plates
    step = (plates.right_y0 - plates.left_y0) / np.hypot(1.0, plates.slope)  # + when the right side is higher
    height = abs(step)
    if not (MIN_STEP_M <= height <= MAX_STEP_M):
        return NoFit("the step is not a lap plate's thickness (1.5-7 mm)")
    if height < MIN_STEP_SIGMAS * plates.sigma:
        return NoFit("the step is within the surfaces' noise")
    if any(_bowed(x[inliers], y[inliers]) for x, y, inliers in (plates.left, plates.right)):
        return NoFit("a plate surface is curved (two crowns of a curved part, not a plate on a plate)")
    # side: +1 when the top plate lies right of (beyond) the edge, the bottom plate toward -s.
    side = 1 if step > 0 else -1
    (bottom, bottom_y0), top = ((plates.left, plates.left_y0), plates.right) if side > 0 else \
        ((plates.right, plates.right_y0), plates.left)
    bottom_reach, bottom_end = _surface_end(bottom[0][bottom[2]], -side)
    top_reach, top_end = _surface_end(top[0][top[2]], side)
    if min(bottom_reach, top_reach) < MIN_PLATE_M:
        return NoFit("less than 5 mm of a plate's surface beside the step")
    gap = side * (top_end - bottom_end)
    # Back to the section frame: (s, t) = s along + t normal.
    plates_along = (along + plates.slope * normal) / np.hypot(1.0, plates.slope)
    plates_normal = np.array([-plates_along[1], plates_along[0]])
    toward = profile.toward
    if toward is not None and gap > _shadow(height, side, plates_along, plates_normal, toward) + SEEN_GAP_M:
        return NoFit("the lower surface stops short of the step where the camera would see it: two parts apart")
    edge_s = top_end if gap > SHADOW_GAP_M else (top_end + bottom_end) / 2
    top_y0 = plates.right_y0 if side > 0 else plates.left_y0
    depth = max(3 * plates.sigma, SURFACE_BAND_M)
    if _dips(bottom, bottom_y0, plates.slope, depth, (edge_s - side * LONG_SURFACE_M, edge_s)) or \
            _dips(top, top_y0, plates.slope, depth, (edge_s + side * SHADOW_GAP_M, edge_s + side * LONG_SURFACE_M)):
        return NoFit("a depression in a plate beside the step (a groove)")
    corner = edge_s * along + (bottom_y0 + plates.slope * edge_s) * normal
    top_edge = corner + height * plates_normal
    outward = -side * plates_along  # the edge face's normal, toward the bottom plate's open side
    split_rad = np.radians(params.lap_torch_split_deg)
    axis = -(np.cos(split_rad) * outward + np.sin(split_rad) * plates_normal)
    outline = [corner - side * plates_along, corner, top_edge, top_edge + side * plates_along]
    if outline[0][0] > outline[-1][0]:
        outline.reverse()
    geometry = JointGeometry(depth_m=float(height), legs_m=(bottom_reach, top_reach))
    return ProfileFit(KIND, float(corner[0]), float(corner[1]), float(axis[0]), float(axis[1]), float(plates.sigma),
                      geometry, tuple((float(a), float(b)) for a, b in outline))  # fmt: skip


def _shadow(height: float, side: int, plates_along: np.ndarray, plates_normal: np.ndarray, toward) -> float:
    """How far (m) the top plate's edge, `height` over the bottom plate, hides the bottom plate
    from the camera (`toward`: the (u, w) unit direction to it): height x tan of the line of sight
    from the plates' normal, where the camera lies over the top plate's side (`side` along
    `plates_along`); none where it lies over the bottom plate's (it sees the edge face)."""
    over, up = float(np.dot(toward, plates_along)) * side, float(np.dot(toward, plates_normal))
    return height * over / up if over > 0 and up > 0 else 0.0


def _bowed(x: np.ndarray, y: np.ndarray) -> bool:
    """Whether a surface's points (x, y) bow from a straight line by more than MAX_BOW_M beyond
    BOW_SIGMAS times the bow's own uncertainty: the quadratic term c of y = a + b x + c z, z the
    centred x^2 (least squares, c = sum(z y) / sum(z^2)), bows the surface by |c| h^2 over its half
    extent h, known to sigma h^2 / sqrt(sum(z^2)) (sigma: the robust noise about the quadratic)."""
    if len(x) < MIN_SIDE_POINTS:
        return False
    centred = x - mean(x)
    z = centred * centred
    z = z - mean(z)
    spread = float(z @ z)
    if spread <= 0.0:
        return False
    intercept, slope = line(centred, y)
    c = float(z @ (y - intercept - slope * centred)) / spread
    half = float(np.ptp(x)) / 2
    sigma = noise(y - intercept - slope * centred - c * z)
    return abs(c) * half * half - BOW_SIGMAS * sigma * half * half / np.sqrt(spread) > MAX_BOW_M


def _dips(surface, y0: float, slope: float, depth: float, stretch: tuple[float, float]) -> bool:
    """Whether a plate's points (x, y, on-line mask; its line y0 + slope x) within the `stretch`
    of x dip below it: more than DEPRESSION_FRACTION of them (and at least MIN_SIDE_POINTS) lie
    over `depth` below. A lap's plates run flat into the corner and out to the edge (the edge's
    mixed points, within SHADOW_GAP_M of it, aside); a groove beside a step leaves points below
    them."""
    x, y, _ = surface
    low, high = sorted(stretch)
    near = (x >= low) & (x <= high)
    below = near & (y < y0 + slope * x - depth)
    return np.count_nonzero(below) >= max(MIN_SIDE_POINTS, DEPRESSION_FRACTION * np.count_nonzero(near))


def _parallel_surfaces(x: np.ndarray, y: np.ndarray) -> _Plates | NoFit:
    """Two parallel straight surfaces left and right of a break in points (x, y) (x ascending),
    or NoFit."""
    split = _best_step(x, y)
    if split is None:
        return NoFit("too few points for two surfaces")
    sides = []
    for part, away in ((slice(0, split), -1), (slice(split, len(x)), 1)):
        px, py = x[part], y[part]
        inliers = _on_line(px, py, away)
        if fraction(inliers) < MIN_INLIER_FRACTION or np.count_nonzero(inliers) < MIN_SIDE_POINTS:
            return NoFit("a plate surface is not a straight line")
        sides.append((px, py, inliers, line(px[inliers], py[inliers])[1]))
    (lx, ly, left_in, left_slope), (rx, ry, right_in, right_slope) = sides
    long_sides = min(np.ptp(lx[left_in]), np.ptp(rx[right_in])) >= LONG_SURFACE_M
    if long_sides and abs(np.degrees(np.arctan(left_slope) - np.arctan(right_slope))) > MAX_SKEW_DEG:
        return NoFit("the two surfaces are not parallel")
    # The edge face's points beside the break lean on one side's line: the two lines, fitted
    # parallel, take the inliers of each other's slope.
    for _ in range(PARALLEL_ROUNDS):
        slope, left_y0, right_y0, sigma = _parallel_lines(lx[left_in], ly[left_in], rx[right_in], ry[right_in])
        limit = max(3 * sigma * np.hypot(1.0, slope), SURFACE_BAND_M)
        left_in = np.abs(ly - (left_y0 + slope * lx)) <= limit
        right_in = np.abs(ry - (right_y0 + slope * rx)) <= limit
        if min(np.count_nonzero(left_in), np.count_nonzero(right_in)) < MIN_SIDE_POINTS:
            return NoFit("a plate surface is not a straight line")
    slope, left_y0, right_y0, sigma = _parallel_lines(lx[left_in], ly[left_in], rx[right_in], ry[right_in])
    return _Plates(slope, (lx, ly, left_in), (rx, ry, right_in), left_y0, right_y0, sigma)


def _best_step(u: np.ndarray, w: np.ndarray) -> int | None:
    """The break (index of the first point right of it) minimising the residual sum of squares of
    two parallel lines, w = a_left + b u left of it and a_right + b u right of it, or None: from
    running sums, with the common slope b = (Cuw_left + Cuw_right) / (Cuu_left + Cuu_right) of
    the centred sums."""
    n = len(u)
    splits = np.arange(MIN_SIDE_POINTS, n - MIN_SIDE_POINTS + 1)
    if len(splits) == 0:
        return None
    sums = np.cumsum(np.column_stack([np.ones(n), u, w, u * u, u * w, w * w]), axis=0)
    left = sums[splits - 1]
    right = sums[-1] - left
    cuu, cuw, cww = (_centred(left, i, j) + _centred(right, i, j) for i, j in ((1, 1), (1, 2), (2, 2)))
    error = cww - np.divide(cuw * cuw, cuu, out=np.zeros_like(cuw), where=cuu > 1e-12)
    return int(splits[int(np.argmin(error))])


def _centred(sums: np.ndarray, i: int, j: int) -> np.ndarray:
    """Centred cross sum of columns i and j from the running sums [1, u, w, uu, uw, ww]:
    S_ij - S_i S_j / count."""
    product = {(1, 1): 3, (1, 2): 4, (2, 2): 5}[(i, j)]
    return sums[:, product] - sums[:, i] * sums[:, j] / sums[:, 0]


def _on_line(x: np.ndarray, y: np.ndarray, away: int) -> np.ndarray:
    """Which points of one side lie on its surface: a line started through the half of them
    farthest from the break (toward `away`: -1 the lower x; what lies near the break, an edge
    face or a slot's floor, does not tilt it), then twice the points within max(3 sigma, SURFACE_BAND_M)
    of the line and the line through them."""
    inliers = away * (x - median(x)) >= 0
    for _ in range(2):
        if np.count_nonzero(inliers) < MIN_SIDE_POINTS:
            break
        intercept, slope = line(x[inliers], y[inliers])
        residual = y - (intercept + slope * x)
        inliers = np.abs(residual) <= max(3 * noise(residual), SURFACE_BAND_M)
    return inliers


def _parallel_lines(lu, lw, ru, rw) -> tuple[float, float, float, float]:
    """(slope, left intercept, right intercept, robust noise) of two parallel lines through the
    left and right points."""
    lu_mean, lw_mean, ru_mean, rw_mean = mean(lu), mean(lw), mean(ru), mean(rw)
    dlu, dru = lu - lu_mean, ru - ru_mean
    slope = float((dlu @ (lw - lw_mean) + dru @ (rw - rw_mean)) / max(dlu @ dlu + dru @ dru, 1e-18))
    left_w0, right_w0 = lw_mean - slope * lu_mean, rw_mean - slope * ru_mean
    residual = np.concatenate([lw - (left_w0 + slope * lu), rw - (right_w0 + slope * ru)])
    return slope, float(left_w0), float(right_w0), noise(residual) / np.hypot(1.0, slope)


def _surface_end(s: np.ndarray, away: int) -> tuple[float, float]:
    """(reach, end) of one surface's points at positions s along the plates, running away from
    the edge toward `away` (+1: increasing s): its point nearest the edge, and how far from it
    the points run on with gaps of at most MAX_SURFACE_SPACING_M."""
    ordered = np.sort(s)[::away]  # nearest the edge first
    gaps = np.flatnonzero(np.abs(np.diff(ordered)) > MAX_SURFACE_SPACING_M)
    last = ordered[gaps[0]] if len(gaps) else ordered[-1]
    return float(abs(last - ordered[0])), float(ordered[0])
