"""The single bevel (half V) model: a plate surface on both sides, one plate's edge square, the
other's bevelled 25-55 degrees from the plate normal.

The plate surface and the depression below it as for the V-groove (SortedProfile.surface); the
profile is then read along the surface: x along it, depth below it. Either wall may be hidden:
seen square on, the bevel faces the camera and the square wall is unseen; from aside, the square
wall may face the camera while the bevel grazes away. The model tries each side as the bevel:
- the bevel wall seen: a straight line through the depression's points clear of the square wall,
  at a bevel's slope, falling toward the square side; its top edge is where it meets the surface;
- the bevel hidden: its edge is where the surface ends on its side, which needs the square wall
  seen (a straight wall square to the surface: else a V with a hidden wall looks the same).
The square edge is its wall's line where seen, else where the surface ends on its side (the
camera sees a surface up to its edge; half a point spacing past its last point). The seam point
is the midpoint of the two edges on the surface line; the torch axis is perpendicular to it.
"""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit
from weldseam.pipeline.joints.profile import SortedProfile
from weldseam.pipeline.joints.robust import fraction, line, median, middle, noise, upper_decile
from weldseam.pipeline.joints.v_groove import largest_run

KIND = JointKind.BEVEL
# The surface line is fitted to the outer halves of the window: the groove must sit in its middle.
CENTRED = True
MIN_LENGTH_M = 0.0
# A single bevel is a V-groove whose one wall is square.
SPECIALISES = JointKind.V_GROOVE
# The bevel wall's slope (depth per m along the surface): 25-55 degrees from the plate normal.
MIN_BEVEL_SLOPE = 1 / np.tan(np.radians(55.0))
MAX_BEVEL_SLOPE = 1 / np.tan(np.radians(25.0))
# A square wall's points lie within this of one position along the surface (a wall within ~10
# degrees of the plate normal, over the few mm seen of it).
SQUARE_WALL_M = 0.0008
# A wall is seen when at least MIN_WALL_POINTS of the depression's points lie on it, and a
# straight wall when MIN_WALL_FRACTION of its side's points lie within max(3 sigma, WALL_BAND_M)
# of its line.
MIN_WALL_POINTS = 4
MIN_WALL_FRACTION = 0.7
WALL_BAND_M = 0.0005
# A seen square wall reaches at least this far down, its points leaning by at most this along the
# surface per depth (x on depth: the surface's noise spreads x, not the slope): 15 degrees. A
# V-groove's wall within SQUARE_WALL_M of its edge, 1-2 mm deep there, leans 0.4-0.8.
MIN_SQUARE_DEPTH_M = 0.001
MAX_SQUARE_LEAN = np.tan(np.radians(15.0))
# A bevel's root lies within this of the square edge when that wall is hidden (root gap 0-2 mm):
# a V's hidden wall leaves its surface ending half the opening from the bottom.
MAX_ROOT_GAP_M = 0.0025
# A wall's top edge lies within this of where the surface ends on its side.
EDGE_TOLERANCE_M = 0.0015
# A surface's points with a wider gap between them are not one stretch of surface.
SURFACE_GAP_M = 0.002


def fit(profile: SortedProfile) -> ProfileFit | NoFit:
    """The single bevel in a profile, or why there is none."""
    u, w, params, surface = profile.u, profile.w, profile.params, profile.surface
    if isinstance(surface, NoFit):
        return surface
    intercept, slope, on_surface, _, depth_limit, sigma = surface
    norm = np.hypot(1.0, slope)
    along, normal = np.array([1.0, slope]) / norm, np.array([-slope, 1.0]) / norm
    x = u * along[0] + (w - intercept) * along[1]
    depth = -(u * normal[0] + (w - intercept) * normal[1])
    groove = largest_run(x, np.flatnonzero(depth > depth_limit))
    if len(groove) < MIN_WALL_POINTS:
        return NoFit("no depression below the surface")
    ends = []
    for beyond, toward in ((x < x[groove].min(), 1), (x > x[groove].max(), -1)):
        side = on_surface & beyond
        if np.count_nonzero(side) < 4:
            return NoFit("no plate surface on both sides of the depression")
        ends.append(_surface_end(x[side], toward))
    deepest = upper_decile(depth[groove])
    if deepest < params.groove_min_depth_m:
        return NoFit("depression shallower than joints.groove_min_depth_m")
    sides = [edges for edges in (_edges(x, depth, groove, ends, side, depth_limit, sigma) for side in (0, 1))
             if edges is not None]
    if not sides:
        return NoFit("no bevel wall and square wall")
    bevel_x, square_x, bevel_slope = min(sides, key=lambda edges: edges[3])[:3]
    centre = (bevel_x + square_x) / 2
    seam = centre * along + intercept * np.array([0.0, 1.0])
    toward = np.sign(square_x - bevel_x)  # from the bevel's edge toward the square one
    root_x = square_x if bevel_slope is None else bevel_x + toward * deepest / bevel_slope
    bevel_deg = None if bevel_slope is None else float(np.degrees(np.arctan(1.0 / bevel_slope)))
    geometry = JointGeometry(opening_m=float(abs(square_x - bevel_x)), depth_m=deepest, included_deg=bevel_deg)
    outline_x = np.array([bevel_x - toward, bevel_x, root_x, square_x, square_x, square_x + toward])
    outline_depth = np.array([0.0, 0.0, deepest, deepest, 0.0, 0.0])
    outline = outline_x[:, None] * along + (intercept * np.array([0.0, 1.0]) - outline_depth[:, None] * normal)
    if toward < 0:
        outline = outline[::-1]
    return ProfileFit(KIND, float(seam[0]), float(seam[1]), float(-normal[0]), float(-normal[1]), sigma, geometry,
                      tuple((float(a), float(b)) for a, b in outline))  # fmt: skip


def _edges(x_all, depth_all, groove, ends, bevel_side: int, depth_limit: float, sigma: float):
    """(bevel edge, square edge, bevel slope or None (hidden), score) along the surface with the
    bevel on side `bevel_side` (0: lower x) of the depression (the points `groove` of the profile's
    x_all, depth_all), `ends` the surface's (last point, edge past it) on each side, or None where
    the depression is not so.
    The depression's points find the bevel wall and how far down it reaches; its line is then
    fitted again to every point between that reach and the outer of the line's edge and the bevel
    side's last surface point, chosen by position. Chosen by depth (the depression's, deeper than
    depth_limit), the variable the line is fitted to, the wall's top keeps only the points noise
    pushed down: the line comes out flatter, its edge outward of the true one, where the window
    then starts and takes in the top points that passed for surface.
    The bevel wall's edge lies within EDGE_TOLERANCE_M of the surface's last point on its side, or
    within depth_limit / slope (m) of it: a wall point passes for surface down to `depth_limit`
    below it (a shallow bevel in 1 mm of noise: 2-5 mm); `sigma`: the surface's noise."""
    (bevel_last, bevel_hidden), (square_last, square_hidden) = ends[bevel_side], ends[1 - bevel_side]
    toward = 1.0 if bevel_side == 0 else -1.0  # from the bevel's side toward the square one
    x, depth = x_all[groove], depth_all[groove]
    near_square = np.abs(x - square_last) <= SQUARE_WALL_M + np.abs(square_hidden - square_last)
    square = _square_wall(x[near_square], depth[near_square])
    square_x = square_hidden if square is None else square
    clear = toward * (square_x - x) > SQUARE_WALL_M  # the depression's points off the square wall
    bevel = _bevel_wall(x[clear], depth[clear], toward, sigma)
    if bevel is not None:
        start = min(bevel_last, bevel[0], key=lambda v: toward * v)  # the outer of the two
        on_wall = (toward * (x_all - start) >= 0) & (toward * (bevel[3] - x_all) >= 0)
        bevel = _bevel_wall(x_all[on_wall], depth_all[on_wall], toward, sigma) or bevel
    if bevel is not None:
        bevel_x, bevel_slope, score, root_x = bevel
        if abs(bevel_x - bevel_last) > max(EDGE_TOLERANCE_M, depth_limit / bevel_slope):
            return None
        if square is None and abs(square_x - root_x) > MAX_ROOT_GAP_M:
            return None  # a V with its other wall hidden: that wall's edge lies out at its mirror image
        return bevel_x, square_x, bevel_slope, score
    if square is None or np.count_nonzero(clear) >= MIN_WALL_POINTS:
        return None  # neither wall seen, or points on the bevel's side that are no bevel
    return bevel_hidden, square_x, None, float("inf")


def _square_wall(x: np.ndarray, depth: np.ndarray) -> float | None:
    """Where a square wall stands along the surface (the median x of its points), or None when
    its points (those near the square side's surface end) do not reach MIN_SQUARE_DEPTH_M down
    within SQUARE_WALL_M of one place, or lean along the surface by more than MAX_SQUARE_LEAN
    per depth (a line x = a + b depth through them)."""
    if len(x) < MIN_WALL_POINTS:
        return None
    position = median(x)
    on_wall = np.abs(x - position) <= SQUARE_WALL_M
    if np.count_nonzero(on_wall) < MIN_WALL_POINTS or np.ptp(depth[on_wall]) < MIN_SQUARE_DEPTH_M:
        return None
    _, lean = line(depth[on_wall], x[on_wall])  # x per m of depth: 0 square, tan(wall angle) sloped
    return position if abs(lean) <= MAX_SQUARE_LEAN else None


def _bevel_wall(x: np.ndarray, depth: np.ndarray, toward: float, surface_sigma: float):
    """(edge, slope, noise, root) of a straight bevel wall through the points (x, depth), falling
    toward `toward` at a bevel's slope, or None: a robust line depth = c + m x refitted twice to
    the points within max(3 sigma, WALL_BAND_M), MIN_WALL_FRACTION of them on it, sigma the noise
    of its points about it but no less than the plate surface's (`surface_sigma`: one sensor sees
    both, and the noise of a few wall points trimmed at 3 sigma shrinks with each refit); its edge
    at depth 0, its root where its points end toward the square side."""
    if len(x) < MIN_WALL_POINTS:
        return None
    inliers = np.ones(len(x), bool)
    for _ in range(2):
        c, m = line(x[inliers], depth[inliers])
        residual = depth - (c + m * x)
        inliers = np.abs(residual) <= max(3 * max(noise(residual[inliers]), surface_sigma), WALL_BAND_M)
        if np.count_nonzero(inliers) < MIN_WALL_POINTS:
            return None
    c, m = line(x[inliers], depth[inliers])
    if fraction(inliers) < MIN_WALL_FRACTION or not (MIN_BEVEL_SLOPE <= toward * m <= MAX_BEVEL_SLOPE):
        return None
    root = float((toward * x[inliers]).max() * toward)
    return float(-c / m), float(toward * m), noise(depth[inliers] - (c + m * x[inliers])), root


def _surface_end(x: np.ndarray, toward: int) -> tuple[float, float]:
    """(last point, edge) of a surface's points x along the surface, the depression lying toward
    `toward` (+1: higher x): its point nearest the depression in the stretch its points fill from
    the far side with gaps of at most SURFACE_GAP_M (a wall's top points, which pass for surface,
    lie apart), and half the median gap of its last few points past it, where its edge lies on
    average."""
    ordered = np.sort(x)[::toward]  # from the far side toward the depression
    gaps = np.flatnonzero(np.diff(ordered) * toward > SURFACE_GAP_M)
    ordered = ordered[: gaps[0] + 1] if len(gaps) else ordered
    last = ordered[::-1][:6]  # nearest the depression first
    spacing = middle(np.abs(np.diff(last))) if len(last) > 1 else 0.0
    return float(last[0]), float(last[0] + toward * spacing / 2)

