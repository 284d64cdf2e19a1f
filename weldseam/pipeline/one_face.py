"""An inside corner with one face unseen: a T-joint seen from nearly above.

A camera looking down a T-joint's web sees the web's face at a grazing angle, past the sensor's
incidence limit (~75 degrees): the scan holds the flange up to the web's foot and the web's top,
and nothing of the web's face. In a section the flange is one face that ends at a point E, with
no surface beyond it in the window, which a plate's outer edge shows too. What tells them apart
is what the camera sees past E: looking at where the flange would go on, the line of sight meets
the web's top edge, nearer the camera and at least a face's length above the flange; past a
plate's edge it meets the table below, or nothing.

The corner is E (the camera sees the flange up to the web's foot: the web's face is the one it
cannot see), the unseen face runs from E to the nearest surface on that line of sight (the web's
top edge, whose face was too oblique to measure), and the torch axis is the bisector of the two
faces. That face must be seen edge-on or nearly (a wall the camera sees from behind hides the
flange's end: past it is the wall's far side's shadow, not its foot). A fit records that one
face was not seen (JointGeometry.faces_seen = 1).
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
# The line of sight is taken these distances past the face's end, nearest first: just past the
# foot of a wall seen edge-on it may leave through the unseen face itself, further in through the
# wall's top.
PAST_END_M = (0.003, 0.006, 0.010)
# An unseen wall's face is seen at more than 70 degrees of incidence (the sensor's limit is ~75;
# a face seen more squarely than that would have been measured), and from its front (a few
# degrees of slack for an edge-on face).
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


def one_face_corner(u, w, toward, sight, params: JointsConfig, half_width_m: float):
    """The corner of a profile (u ascending, m; the window |u| <= half_width_m) where a straight face
    ends at a gap in the points, or short of the window's edge, and the camera sees a wall's top
    past it, or None (the end nearest the section's centre when several qualify). `toward`:
    (u, w) of the unit direction toward the camera in the section plane. sight(u, w) -> (u, w) of
    the nearest scan point on the line of sight through the profile point (u, w) that is at least a
    fillet leg nearer to the camera, or None."""
    if len(u) < 12:
        return None
    faces = _faces(u, w, np.split(np.arange(len(u)), np.flatnonzero(np.diff(u) > GAP_M) + 1))
    found = []
    for k, face in enumerate(faces):
        for side in (1, -1):  # the face's right end, its left end
            if not 0 <= k + side < len(faces) and half_width_m - abs(u[face[-1] if side > 0 else face[0]]) < GAP_M:
                continue  # the face runs out of the window
            corner = _corner(u[face], w[face], side, toward, sight, params)
            if corner is not None:
                found.append(corner)
    return min(found, key=lambda fit: abs(fit.u)) if found else None


def _faces(u, w, runs: list[np.ndarray]) -> list[np.ndarray]:
    """The runs of points between gaps joined where a run goes on along the line of the ones
    before it (within 2 FACE_TOLERANCE_M, median): a hole in a face, not its end."""
    faces = [runs[0]]
    for run in runs[1:]:
        intercept, slope = line(u[faces[-1]], w[faces[-1]])
        if middle(np.abs(w[run] - (intercept + slope * u[run]))) <= 2 * FACE_TOLERANCE_M:
            faces[-1] = np.concatenate([faces[-1], run])
        else:
            faces.append(run)
    return faces


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
    top = next((found for past in PAST_END_M if (found := sight(*(face_end - past * along_face))) is not None), None)
    if top is None:
        return None
    wall = np.asarray(top) - face_end
    if wall @ normal < params.fillet_min_leg_m:
        return None  # nothing a face's length above the face's end: a plate's edge, not a wall
    wall = unit(wall)
    included = float(np.degrees(np.arccos(np.clip(along_face @ wall, -1.0, 1.0))))
    if not MIN_INCLUDED_DEG <= included <= MAX_INCLUDED_DEG:
        return None
    axis = -unit(along_face + wall)
    geometry = JointGeometry(included_deg=included, legs_m=None, faces_seen=1)
    outline = (tuple(face_end + along_face), tuple(face_end), tuple(face_end + wall))
    residual_m = middle(np.abs(residual[inliers]))
    return ProfileFit(JointKind.FILLET, float(face_end[0]), float(face_end[1]), float(axis[0]), float(axis[1]),
                      residual_m, geometry, tuple((float(a), float(b)) for a, b in outline))  # fmt: skip
