"""The V-groove model: a plate surface on both sides with a depression between them.

A reference line through the plate surface on both sides (an upper-envelope robust fit), a
depression below it at least `groove_min_depth_m` deep with surface on both sides, and a line
fitted to each groove wall. Each groove edge is where its wall line meets the reference line
(where a wall is hidden, the last surface point before the hole). The seam point is the
midpoint of the two edges on the reference line; the torch axis is perpendicular to the
reference line, fitted within `face_radius_m` beside the edges.
"""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit
from weldseam.pipeline.joints.profile import SortedProfile
from weldseam.pipeline.joints.robust import line, median, noise, upper_decile

KIND = JointKind.V_GROOVE
# The surface line is fitted to the outer halves of the window: the groove must sit in its middle.
CENTRED = True
MIN_LENGTH_M = 0.0
SPECIALISES = None
# A groove edge put at the last surface point may lie this far beyond the mirror image of the
# other edge about the groove bottom (_groove_edges). With one wall hidden, the bottom (the
# median of the deepest points) sits up the visible wall, measured up to 1.2 mm, so the mirror
# falls up to ~2.5 mm short; the edges scatter by ~0.5 mm more.
HIDDEN_EDGE_SLACK_M = 0.004
# Points of a depression closer than this across the section belong to one groove.
GROOVE_GAP_M = 0.004
# A wall's line meets the surface at most this far outside the surface's end (its last point above
# the band's lower tail: fit). With 3 mm, the lines of a 1.5 mm square slot's few wall points met it
# out where the surface still runs level (4-6 mm open in 8 of 15 sections: a gap to the table, as
# slots.gap_to_table reads it); with 1 mm, more seen walls' edges were refused in noise (broad
# seeds 0-9 and 80-99: 532 scenes of 630 passing; 3 mm, without holes._confirmed: 538).
EDGE_BEYOND_SURFACE_M = 0.002


def fit(profile: SortedProfile) -> ProfileFit | NoFit:
    """The V-groove in a profile, or why there is none."""
    u, w, params, surface = profile.u, profile.w, profile.params, profile.surface
    if isinstance(surface, NoFit):
        return surface
    intercept, slope, on_surface, residual, depth_limit, sigma = surface
    depth = -residual
    deep = np.flatnonzero(depth > depth_limit)
    if len(deep) < 4:
        return NoFit("no depression below the surface")
    groove = largest_run(u, deep)
    u_start, u_end = u[groove[0]], u[groove[-1]]
    left_surface = on_surface & (u < u_start)
    right_surface = on_surface & (u > u_end)
    if np.count_nonzero(left_surface) < 4 or np.count_nonzero(right_surface) < 4:
        return NoFit("no plate surface on both sides of the depression")
    deepest = upper_decile(depth[groove])
    if deepest < params.groove_min_depth_m:
        return NoFit("depression shallower than joints.groove_min_depth_m")
    # Each surface ends at its last point above the band's lower tail (residual >= -sigma): a wall's
    # shallowest points, and mixed pixels falling off a rim along the line of sight, lie within the
    # band of a noisy surface, below its line.
    level = residual >= -sigma
    left_end = u[left_surface & level].max(initial=u[left_surface].min())
    right_end = u[right_surface & level].min(initial=u[right_surface].max())
    edges = _groove_edges(u, depth, groove, left_end, right_end, slope)
    if isinstance(edges, NoFit):
        return edges
    u_left, u_right, slopes, bottom_u = edges
    # The surface beside the seam, within face_radius of each edge, sets the torch axis.
    face = params.face_radius_m
    beside = on_surface & (((u >= u_left - face) & (u <= u_left)) | ((u >= u_right) & (u <= u_right + face)))
    if np.count_nonzero(beside) >= 6:
        intercept, slope = line(u[beside], w[beside])
    centre_u = (u_left + u_right) / 2
    norm = np.hypot(1.0, slope)
    walls = [abs(s) for s in slopes if s is not None]
    included = 180.0 - float(np.degrees(np.arctan(walls).sum())) if len(walls) == 2 else None
    geometry = JointGeometry(opening_m=u_right - u_left, depth_m=deepest, included_deg=included)
    # The surface beside the edges, the walls down to the bottom (a metre of ray each side).
    outline_u = np.array([u_left - 1.0, u_left, bottom_u, u_right, u_right + 1.0])
    outline_w = intercept + slope * outline_u - np.array([0.0, 0.0, deepest, 0.0, 0.0])
    return ProfileFit(KIND, centre_u, intercept + slope * centre_u, slope / norm, -1.0 / norm, sigma, geometry,
                      tuple(zip(outline_u.tolist(), outline_w.tolist())))  # fmt: skip


def largest_run(u: np.ndarray, deep: np.ndarray) -> np.ndarray:
    """The largest run of the `deep` points (indices), taken in order of u, with gaps under
    GROOVE_GAP_M between them (the first of the largest)."""
    deep = deep[np.argsort(u[deep], kind="stable")]
    breaks = np.flatnonzero(np.diff(u[deep]) > GROOVE_GAP_M) + 1
    if not len(breaks):
        return deep
    bounds = np.concatenate(([0], breaks, [len(deep)]))
    longest = int(np.argmax(np.diff(bounds)))
    return deep[bounds[longest] : bounds[longest + 1]]


def _groove_edges(u, depth, groove, left_surface_end, right_surface_end, surface_slope: float):
    """(left edge, right edge, [left wall slope, right wall slope], bottom u) where each groove
    wall meets the surface (depth 0), and where the groove is deepest, or NoFit when neither wall is seen: a bevelled wall facing the camera
    is always visible, so a depression with two hidden (vertical) walls is a hole or a slot, not
    a V-groove.

    Each wall is the points between the last surface point and the groove bottom (its middle
    15-80 %); a robust line depth = c + m u through them is solved for depth 0.
    A wall too short to fit on its own takes the other wall's slope mirrored (bevels are
    symmetric) and fits only its offset. A hidden wall (no points: it faces away from the
    camera) ends at the last surface point, which the camera sees right up to the edge.
    Such an edge (or one whose wall line meets the surface out of range) lying more than
    HIDDEN_EDGE_SLACK_M beyond the mirror image of the other edge about the groove bottom is
    not seen: a dropout or a shadow goes on past it onto the plate, and there is no fit. The
    bottom is mirrored about its foot on the surface line w = c + s u (`surface_slope` s;
    `depth` is measured vertically from that line): u - depth s / (1 + s^2).
    Each surface ends at its last point above its band's lower tail (fit): a wall's shallowest
    points lie within the band of a noisy surface, and ended there the surface lay ~1 mm inside
    the edge, by a bias that differs side to side.
    """
    deepest = upper_decile(depth[groove])
    bottom = median(u[groove][depth[groove] >= 0.8 * deepest])
    # Wall points are chosen by position across the groove, never by depth: choosing by the
    # fitted variable would bias the line where the noise differs between the walls.
    walls = []
    for surface_end in (left_surface_end, right_surface_end):
        near, far = surface_end + 0.15 * (bottom - surface_end), surface_end + 0.8 * (bottom - surface_end)
        low, high = sorted((near, far))
        walls.append(np.flatnonzero((u >= low) & (u <= high)))
    slopes = [_wall_slope(u[wall], depth[wall], side) for wall, side in zip(walls, (-1, 1))]
    if slopes == [None, None]:
        return NoFit("neither groove wall seen")
    edges, at_surface_end = [], []
    for side, wall, slope, other, surface_end in zip(
        (-1, 1), walls, slopes, slopes[::-1], (left_surface_end, right_surface_end)
    ):
        if slope is None and other is not None and len(wall) >= 2:
            slope = -other
        edge = None
        if slope is not None:
            edge = -median(depth[wall] - slope * u[wall]) / slope
            # Between EDGE_BEYOND_SURFACE_M outside the surface's end and the middle of the wall.
            low, high = sorted((surface_end + side * EDGE_BEYOND_SURFACE_M, float(np.add.reduce(u[wall])) / len(wall)))
            edge = edge if low <= edge <= high else None
        at_surface_end.append(edge is None)
        edges.append(float(surface_end if edge is None else edge))
    foot = bottom - deepest * surface_slope / (1 + surface_slope**2)
    for side, edge, other, unseen in zip((-1, 1), edges, edges[::-1], at_surface_end):
        if unseen and side * (edge - (2 * foot - other)) > HIDDEN_EDGE_SLACK_M:
            return NoFit("a hidden groove wall's edge lies beyond the other's mirror image (a dropout)")
    return edges[0], edges[1], slopes, bottom


def _wall_slope(u: np.ndarray, depth: np.ndarray, side: int) -> float | None:
    """Slope of a robust line through one wall's points (`u` ascending), or None when there are
    too few or the line is not steep toward the middle (at least 11 degrees)."""
    if len(u) < 4 or u[-1] - u[0] < 0.0006:
        return None
    intercept, slope = line(u, depth)
    residual = depth - (intercept + slope * u)
    inliers = np.abs(residual) <= 2.5 * noise(residual)
    if np.count_nonzero(inliers) >= 4:
        intercept, slope = line(u[inliers], depth[inliers])
    return slope if slope * side < -0.2 else None
