"""The square butt model (I-groove): two coplanar plate surfaces with a narrow opening between
them, and no bevel.

A reference line through the plate surface on both sides (SortedProfile.surface), and an opening
in it within REACH_M of the window's centre: two neighbouring surface points u_left < u_right with
joints.gap_min_m <= u_right - u_left <= joints.gap_max_m. What lies between them is nothing (a
dropout along the gap) or lies deeper than the surface (the table or the far side seen through the
gap, its walls), never above it. It is the widest opening between neighbouring surface points
within `face_radius_m` (a wider one beside it is the joint: a groove's opening, with a wall's
points just inside it), and one through which nothing deeper was seen (no deeper point within
SEEN_THROUGH_M of it) at least UNIQUE_RATIO x as wide as any other there: one
pixel lattice leaves openings of one pitch everywhere on a plate (on our own scenes, 1.3-3 mm gaps
seen from 0.4-0.7 m, sections within 0.7 mm of the gap fit 70 % of the time, random sections on
plain surfaces 3.4 %; the trace needs most sections of a chain to agree, and consistent seam
points). Counting what was seen just beside the rims raised the sections on the gap that fit,
in the broad world's noisy scans, from 55 to 87 % (square_butt_3) and from 46 to 64 %
(square_butt_2), and left random sections on flat plates at 0.7-4 %. Failing that, it is the
opening the sensor's image shows, however wide the lattice's others: the one holding most of the
section's image openings (where lines of pixels that returned nothing cross it: gaps.py). Failing
that too, where the image's crossings near the centre lie together, it is the opening between the
surface points either side of them, however narrow: the pixels over a gap's rims see the plates,
so the cloud narrows it (an independent scan's 1.07 mm gap seen from 0.43 m, 0.7 mm pixels, leaves
0.4-0.7 mm between the cloud's points, under gap_min_m, in sections where the image's crossings
lie within 0.2 mm of its centre); it need only be wider than the lattice's step. The two
sides each hold a plate surface, and lines fitted to them agree (one plane: a step or a bend is no
gap).

The seam point lies on the reference line at the median u of the image's crossings within
SEEN_THROUGH_M of the opening where nothing deeper was seen through it, else at its middle,
u = (u_left + u_right) / 2. Each crossing is the middle between the pixels either side of the gap
in one line of the image. Where the sensor returned nothing from the gap, the cloud's opening is
narrowed from one side by the pixels straddling that rim, whose depth, between the plate's and
what lies under it, falls within the surface's noise band (an independent scan's 1.07 mm gap: the
openings' middles over 1 mm off the gap in a fifth of its sections, the crossings within 0.3 mm of
it but beside a dropout's blob). Where the far wall or the floor was seen through it, a line's
crossing ends on the wall's points that range noise brought nearer the camera, and lies off
toward the camera by 0.3-0.8 mm (our own scenes' 3 mm gap seen 30 degrees off); the opening's
rims, a plate's edge and the wall's top, are the better measure there. The torch axis is
perpendicular to the reference line fitted within `face_radius_m` beside the opening. The
opening measured is u_right - u_left less one surface spacing (each rim lies on average half a
spacing inside its edge).
"""

from __future__ import annotations

import numpy as np

from weldseam.config import JointsConfig
from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit
from weldseam.pipeline.joints.profile import SortedProfile
from weldseam.pipeline.joints.robust import line, median, one_plane, upper_decile

KIND = JointKind.SQUARE_BUTT
# The surface line is fitted to the outer halves of the window: the opening must sit in its middle.
CENTRED = True
# Two plates' butt runs their length between their corners; a shorter straight opening is a strip of a
# sensor's dropout between two stretches of one surface (missing pixels that return nothing, as a
# gap does).
MIN_LENGTH_M = 0.05
SPECIALISES = None
UNIQUE_RATIO = 1.3
# Openings are sought this close to the window's centre: sections are centred on the joint (an
# extension's prediction drifts by a mm or two), and across a whole window a plate's sampling
# offers a unique opening in one section of three.
REACH_M = 0.003
# Each side of the opening holds at least this many surface points within face_radius_m, spread
# over at least SIDE_EXTENT of face_radius_m: a plate, not a few points at an edge.
MIN_SIDE_POINTS = 6
SIDE_EXTENT = 0.5
# The lines fitted to the two sides meet the opening's centre within this of each other, at
# slopes within COPLANAR_RAD: the two plates of a butt joint lie in one plane (a step or a bend
# between two faces is no gap).
COPLANAR_M = 0.001
COPLANAR_RAD = np.radians(8.0)
# Deeper points within this of an opening's rims were seen through it: seen obliquely, the gap's
# far wall stands at one rim, and the fine cloud's 1 mm voxels merge its top with the surface
# beside it, so its deeper points lie up to a voxel beyond the rim rather than between the rims.
SEEN_THROUGH_M = 0.001
# The image's crossings of one straight gap lie within this of their median: each is the middle
# between the pixels either side of the gap, within half a pixel's footprint (0.55 mm at 0.7 m) of
# its centre. A sparse surface's scattered dropouts put two crossings a mm or more apart.
CROSSING_SPREAD_M = 0.0005
# An opening the image shows is the gap only where it spans this many of the lattice's median steps.
LATTICE_STEPS = 1.5


def fit(profile: SortedProfile) -> ProfileFit | NoFit:
    """The square butt joint in a profile, or why there is none."""
    u, w, params, surface = profile.u, profile.w, profile.params, profile.surface
    if isinstance(surface, NoFit):
        return surface
    intercept, slope, on_surface, residual, depth_limit, sigma = surface
    found = _opening(u, residual, on_surface, profile.openings_u, params)
    if isinstance(found, NoFit):
        return found
    u_left, u_right = found
    face = params.face_radius_m
    beside = on_surface & (((u >= u_left - face) & (u <= u_left)) | ((u >= u_right) & (u <= u_right + face)))
    centre_u = _centre(u, residual, on_surface, u_left, u_right, profile.openings_u)
    left, right = beside & (u <= u_left), beside & (u >= u_right)
    for side in (left, right):
        if np.count_nonzero(side) < MIN_SIDE_POINTS or np.ptp(u[side]) < SIDE_EXTENT * face:
            return NoFit("no plate surface on both sides of the opening")
    if not one_plane(u, w, (left, right), centre_u, offset_m=COPLANAR_M, angle_rad=COPLANAR_RAD):
        return NoFit("the surfaces beside the opening are not one plane")
    intercept, slope = line(u[beside], w[beside])
    inside = (u > u_left) & (u < u_right)
    depth = (intercept + slope * u[inside]) - w[inside]
    deepest = upper_decile(depth) if len(depth) else None
    norm = np.hypot(1.0, slope)
    spacing = median(np.diff(u[beside]))
    geometry = JointGeometry(opening_m=float(max(u_right - u_left - spacing, 0.0)), depth_m=deepest)
    # The surface beside the opening, its walls straight down to what was seen deepest in it.
    drop = deepest or 0.0
    outline_u = np.array([u_left - 1.0, u_left, u_left, u_right, u_right, u_right + 1.0])
    outline_w = intercept + slope * outline_u - np.array([0.0, 0.0, drop, drop, 0.0, 0.0])
    return ProfileFit(KIND, float(centre_u), float(intercept + slope * centre_u), slope / norm, -1.0 / norm, sigma,
                      geometry, tuple(zip(outline_u.tolist(), outline_w.tolist())))  # fmt: skip


def _centre(u, residual, on_surface, u_left: float, u_right: float, openings_u: np.ndarray) -> float:
    """The seam's u (m): the median of the image's crossings within SEEN_THROUGH_M of the opening
    (u_left, u_right) where nothing deeper was seen through it, else its middle."""
    near = openings_u[_near(openings_u, u_left, u_right)]
    seen_through = _seen_through(u, residual, on_surface, u_left, u_right)
    return median(near) if len(near) and not seen_through else (u_left + u_right) / 2


def _opening(u, residual, on_surface, openings_u, params: JointsConfig):
    """(u_left, u_right) of the opening nearest the window's centre (see the module), or NoFit."""
    rims = np.flatnonzero(on_surface)
    if len(rims) < 2 * MIN_SIDE_POINTS:
        return NoFit("too few surface points")
    spacing = np.diff(u[rims])
    middle = (u[rims[1:]] + u[rims[:-1]]) / 2
    clear = _clear(rims, residual)
    wide = np.flatnonzero((spacing >= params.gap_min_m) & (spacing <= params.gap_max_m) & (np.abs(middle) <= REACH_M)
                          & clear)  # fmt: skip
    for k in sorted(wide, key=lambda k: abs(middle[k])):
        left, right = rims[k], rims[k + 1]
        others = np.abs(middle - middle[k]) <= params.face_radius_m
        others[k] = False
        ratio = 1.0 if _seen_through(u, residual, on_surface, u[left], u[right]) else UNIQUE_RATIO
        if spacing[k] >= ratio * spacing[others].max(initial=0.0):
            return float(u[left]), float(u[right])
    # Where the fine cloud's lattice hides the gap among openings as wide, the image's opening is it,
    # where the lattice's own step is finer (sparse points far off or grazing resolve no gap).
    step = median(spacing)
    for k in sorted(wide, key=lambda k: abs(middle[k])):
        if spacing[k] >= LATTICE_STEPS * step and _in_image(u[rims[k]], u[rims[k + 1]], openings_u):
            return float(u[rims[k]]), float(u[rims[k + 1]])
    crossed = _image_line(u, rims, clear, openings_u, step, params)
    if crossed is not None:
        return crossed
    return NoFit("no opening of joints.gap_min_m..gap_max_m in the surface")


def _clear(rims: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """(len(rims) - 1,) bool: whether no point lies above the surface (residual > 0) between each two
    neighbouring surface points (indices `rims`, ascending): a gap's opening holds nothing over it."""
    above = np.cumsum(residual > 0)  # points above the surface up to each index
    return above[rims[1:] - 1] == above[rims[:-1]]


def _image_line(u, rims, clear, openings_u, step: float, params: JointsConfig):
    """(u_left, u_right): the surface points either side of the image's crossings within REACH_M of
    the centre where those lie within CROSSING_SPREAD_M of their median (one line crossed: a
    dropout's blob, or a sparse surface's dropouts, are crossed all across), at least
    LATTICE_STEPS x `step` and at most gap_max_m apart with nothing above the surface between
    them (`clear`: _clear); else None."""
    near = openings_u[np.abs(openings_u) <= REACH_M]
    if not len(near):
        return None
    centre = median(near)
    k = int(np.searchsorted(u[rims], centre))
    if not (np.all(np.abs(near - centre) <= CROSSING_SPREAD_M) and 0 < k < len(rims)):
        return None
    left, right = rims[k - 1], rims[k]
    if LATTICE_STEPS * step <= u[right] - u[left] <= params.gap_max_m and clear[k - 1]:
        return float(u[left]), float(u[right])
    return None


def _near(values: np.ndarray, u_left: float, u_right: float) -> np.ndarray:
    """(len(values),) bool: which u `values` lie within SEEN_THROUGH_M of the opening (u_left, u_right)."""
    return (values >= u_left - SEEN_THROUGH_M) & (values <= u_right + SEEN_THROUGH_M)


def _in_image(u_left: float, u_right: float, openings_u: np.ndarray) -> bool:
    """Whether the sensor's image shows the opening (u_left, u_right) between two surface points:
    most of the section's image openings (SortedProfile.openings_u) lie near it (_near). A surface
    seen grazing misses pixels all over, and its sections hold image openings all across."""
    return np.count_nonzero(_near(openings_u, u_left, u_right)) > len(openings_u) / 2


def _seen_through(u, residual, on_surface, u_left: float, u_right: float) -> bool:
    """Whether points deeper than the surface lie near the opening (u_left, u_right) between two
    surface points (_near): what the camera saw through it."""
    return bool(np.any(~on_surface & (residual < 0) & _near(u, u_left, u_right)))
