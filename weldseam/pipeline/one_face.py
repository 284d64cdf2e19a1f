"""An inside corner with one face unseen: a T-joint seen from nearly above.

A camera looking down a T-joint's web sees the web's face at a grazing angle, past the sensor's
incidence limit (~75 degrees): the scan holds the flange up to the web's foot and the web's top,
and nothing of the web's face. In a section the flange is one face that ends at a point E, with
no surface beyond it in the window, which a plate's outer edge shows too. What tells them apart
is what the camera sees past E: looking at where the flange would go on, the line of sight meets
the web's top edge, nearer the camera and at least a face's length above the flange; past a
plate's edge it meets the table below, or nothing. Where the flange goes on beyond the web (a
T's flange either side of it), the web's foot and its shadow leave a gap in the flange: a gap with
a wall's top standing over it is where the flange ends, one with nothing over it a dropout.

The corner is E (the camera sees the flange up to the web's foot: the web's face is the one it
cannot see), the unseen face runs from E to the nearest surface on that line of sight (the web's
top edge, whose face was too oblique to measure), and the torch axis is the bisector of the two
faces. That face must be seen edge-on or nearly (a wall the camera sees from behind hides the
flange's end: past it is the wall's far side's shadow, not its foot). A fit records that one
face was not seen (JointGeometry.faces_seen = 1).

A wall's top edge runs along the seam: looked at a little further along, the line of sight meets
it as far along. Past a standing pipe the flange ends at its shadow's edge, which runs along the
line of sight, and every sight past it meets the pipe's one silhouette edge; so does a sight past
the pipe's foot near its silhouette. Such a corner is marked (JointGeometry.outline_wall): by
itself it may be a shadow's edge, and only the curve of a seam fitted with both faces may lead to
it (extend).
"""

from __future__ import annotations

import numpy as np

from weldseam.config import JointsConfig
from weldseam.geometry import unit
from weldseam.pipeline.joints import JointGeometry, JointKind, ProfileFit
from weldseam.pipeline.joints.robust import fraction, line, middle, noise

# A face ends where the next point across the section lies more than GAP_M on; the face must be
# straight: this share of its points within max(3 sigma, FACE_TOLERANCE_M) of its line.
GAP_M = 0.003
FACE_INLIERS = 0.8
FACE_TOLERANCE_M = 0.0005
# Where the camera sees over a gap in a face is looked at these fractions of the way across it.
GAP_SAMPLES = np.array([0.1, 0.3, 0.5, 0.7, 0.9])
# The line of sight is taken these distances past the face's end, nearest first: just past the
# foot of a wall seen edge-on it may leave through the unseen face itself, further in through the
# wall's top.
PAST_END_M = (0.003, 0.006, 0.010)
# An unseen wall's face is seen at more than 70 degrees of incidence (the sensor's limit is ~75;
# a face seen more squarely than that would have been measured), and from its front or exactly
# edge-on: no slack (at 3 degrees, broad seeds 0-9 lost four cases: past a standing pipe's
# silhouette its wall is seen just from behind, and the plate's end there is its shadow's edge).
OBLIQUE_COS = 0.34
EDGE_ON_COS = 0.0
# The unseen face's direction comes from its top edge alone. Past the end of a flange in the
# shadow of a wall the camera sees from behind or at its flank, the line of sight to that wall's
# top passes for the face, tilted from the true one by the camera's tilt. So the face must stand
# square to the flange, as a T-joint's web does (measured 90-93 degrees on independent scans):
# a shadow's end then passes only for tilts under 10 degrees, within a tenth of the wall's height
# of its foot. A corner far from square needs both its faces seen.
MIN_INCLUDED_DEG = 80.0
MAX_INCLUDED_DEG = 100.0
# The unseen wall runs along the seam, and so does its top edge: the line of sight this far along
# the travel meets it as far along. Past a post or pipe the flange ends in its shadow, whose edge
# runs along the line of sight: every sight past it meets the occluder's one silhouette edge.
WALL_STEP_M = 0.006


def one_face_corner(u, w, toward, sight, params: JointsConfig, half_width_m: float):
    """The corner of a profile (u ascending, m; the window |u| <= half_width_m) where a straight face
    ends at a gap in the points, or short of the window's edge, and the camera sees a wall's top
    past it, or None (the end nearest the section's centre when several qualify). `toward`:
    (u, w) of the unit direction toward the camera in the section plane. sight(u, w, along=0) -> (u, w,
    along) of the nearest scan point on the line of sight through the profile point (u, w) moved
    `along` the travel (m) that is at least a fillet leg nearer to the camera, or None."""
    if len(u) < 12:
        return None
    faces = _faces(u, w, np.split(np.arange(len(u)), np.flatnonzero(np.diff(u) > GAP_M) + 1), sight)
    found = []
    for k, face in enumerate(faces):
        for side in (1, -1):  # the face's right end, its left end
            if not 0 <= k + side < len(faces) and half_width_m - abs(u[face[-1] if side > 0 else face[0]]) < GAP_M:
                continue  # the face runs out of the window
            corner = _corner(u[face], w[face], side, toward, sight, params)
            if corner is not None:
                found.append(corner)
    return min(found, key=lambda fit: abs(fit.u)) if found else None


def _faces(u, w, runs: list[np.ndarray], sight) -> list[np.ndarray]:
    """The runs of points between gaps joined where a run goes on along the line of the ones
    before it (within 2 FACE_TOLERANCE_M, median) and no wall stands over the gap (_wall_over at
    GAP_SAMPLES across it, on that line): a hole in a face, not its end. A wall standing on the
    face hides a stretch of it the width of its foot and more, and the face goes on along the
    same line beyond it (a T-joint's flange either side of its web, seen from above)."""
    faces = [runs[0]]
    for run in runs[1:]:
        intercept, slope = line(u[faces[-1]], w[faces[-1]])
        gap = (u[faces[-1][-1]], u[run[0]])
        across = gap[0] + GAP_SAMPLES * (gap[1] - gap[0])
        if (middle(np.abs(w[run] - (intercept + slope * u[run]))) <= 2 * FACE_TOLERANCE_M
                and not any(_wall_over((at, intercept + slope * at), gap, sight) for at in across)):
            faces[-1] = np.concatenate([faces[-1], run])
        else:
            faces.append(run)
    return faces


def _wall_over(looked_at, gap: tuple[float, float], sight) -> bool:
    """Whether the camera sees, over the profile point `looked_at` (u, w) in a gap of a face
    (`gap`: the u of its two sides), the top of a wall standing in the gap and running along the
    seam both ways: the line of sight meets a top whose u lies within the gap, and looked at
    WALL_STEP_M further along the travel and back, meets it at least half as far along each way.
    A wall's foot lies in the gap it leaves in the face, and its top above it; past the end of a
    wall the face lies in its shadow, and the sights over it meet the wall's end, behind."""
    top = sight(*looked_at)
    if top is None or not gap[0] <= top[0] <= gap[1]:
        return False
    return all(_met_along(looked_at, top, sight))  # None (the sight meets nothing) is not met


def _runs_along(looked_at, top, sight) -> bool:
    """Whether the top seen past `looked_at` (u, w) may be the edge of a wall running along the
    seam: looked at WALL_STEP_M further along the travel (or back), the line of sight meets it at
    least half as far along, or meets nothing (a dropout in the top). Not so when what it meets
    stays put: the silhouette of a post or pipe whose shadow the flange ends in."""
    met = [found for found in _met_along(looked_at, top, sight) if found is not None]
    return not met or any(met)


def _met_along(looked_at, top, sight):
    """For the line of sight through `looked_at` (u, w) moved WALL_STEP_M further along the travel,
    then back: None where it meets nothing, else whether it meets a top at least half a step
    farther that way than `top` (u, w, along) lies: a wall's top running along the seam."""
    for step in (WALL_STEP_M, -WALL_STEP_M):
        found = sight(*looked_at, step)
        yield None if found is None else bool((found[2] - top[2]) * np.sign(step) >= WALL_STEP_M / 2)


def _corner(u, w, side, view, sight, params: JointsConfig):
    """The corner where the face of `u`, `w` (one run of points) ends toward `side` (+1: its
    largest u), or None."""
    intercept, slope = line(u, w)
    residual = w - (intercept + slope * u)
    inliers = np.abs(residual) <= max(3 * noise(residual), FACE_TOLERANCE_M)
    if len(u) < 8 or fraction(inliers) < FACE_INLIERS or np.ptp(u[inliers]) < params.fillet_min_leg_m:
        return None
    intercept, slope = line(u[inliers], w[inliers])
    # The face ends at its last point on its line (mixed pixels at the depth edge beyond it are not
    # the face).
    end_u = u[inliers].max() if side > 0 else u[inliers].min()
    face_end = np.array([end_u, intercept + slope * end_u])
    along_face = unit(np.array([-side, -side * slope]))  # from the end back into the face
    normal = unit(np.array([-slope, 1.0]))  # the face's normal, out of the work (w up)
    if np.dot(normal, view) <= 0:
        return None  # the camera sees the face from behind: not a face of this part
    # A wall square to the face at its end faces along the face (back into the corner): the camera
    # must see it edge-on (too oblique to measure), not from behind (then the wall hides the face's
    # end, which is a shadow's edge and not the wall's foot) nor square on (then its missing points
    # are a dropout). Tested before the line of sight is looked up: it needs only the face.
    if not -EDGE_ON_COS <= along_face @ np.asarray(view) <= OBLIQUE_COS:
        return None
    looked = next(((past, top) for past in PAST_END_M if (top := sight(*(face_end - past * along_face))) is not None), None)
    if looked is None:
        return None
    past, top = looked
    wall = np.asarray(top[:2]) - face_end
    if wall @ normal < params.fillet_min_leg_m:
        return None  # nothing a face's length above the face's end: a plate's edge, not a wall
    wall = unit(wall)
    included = float(np.degrees(np.arccos(np.clip(along_face @ wall, -1.0, 1.0))))
    if not MIN_INCLUDED_DEG <= included <= MAX_INCLUDED_DEG:
        return None
    axis = -unit(along_face + wall)
    outline_wall = not _runs_along(face_end - past * along_face, top, sight)
    geometry = JointGeometry(included_deg=included, legs_m=None, faces_seen=1, outline_wall=outline_wall)
    outline = (tuple(face_end + along_face), tuple(face_end), tuple(face_end + wall))
    residual_m = middle(np.abs(residual[inliers]))
    return ProfileFit(JointKind.FILLET, float(face_end[0]), float(face_end[1]), float(axis[0]), float(axis[1]),
                      residual_m, geometry, tuple((float(a), float(b)) for a, b in outline))  # fmt: skip
