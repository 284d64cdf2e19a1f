"""The fillet model (inside corner): two faces meeting at a concave corner, each face straight or
smoothly curved (a pipe's wall, a tube's flank).

Two ways the faces are sought, the first that gives a fillet wins:
1. at a crease: the profile split where a parabola w = c0 + c1 u + c2 u^2 on each side fits
   best (faces.best_break); each side a robust line, or where its curvature is significant a
   parabola near the break (faces.fit_face), both fitted again from the corner they meet at;
   included angle 45-160 degrees (a shallow valley between two tubes too);
2. rounded off: a straight face over each whole side, split where two lines fit best
   (faces.straight_faces, the corner between them rounded or not); included 45-135 degrees.
The seam point is the corner; the torch axis is the bisector of the faces' tangents there,
pointing into the corner. Both faces must rise away from the corner, reach at least
`fillet_min_leg_m` from it, and curve no tighter than MIN_FACE_RADIUS_M: a gentle bend or ripple
of a plate has no crease, a groove's wall and the plate beside it are no face.
"""

from __future__ import annotations

import numpy as np

from weldseam.config import JointsConfig
from weldseam.geometry import unit
from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit
from weldseam.pipeline.joints.faces import (
    MIN_FACE_POINTS, MIN_FACE_RADIUS_M, Face, best_break, fit_face, meeting_point, straight_faces,
)
from weldseam.pipeline.joints.profile import SortedProfile

KIND = JointKind.FILLET
# Where two fitted faces meet does not depend on where the window sits.
CENTRED = False
MIN_LENGTH_M = 0.0
SPECIALISES = None
MIN_INCLUDED_DEG = 45.0
# Two faces meeting at a crease, straight or curved (tubes of a Y-shaped part), make valleys of up
# to 150 degrees; past 160 a "corner" is within what noise and ripple bend a plate. Two straight
# faces over the whole sides, their corner rounded off, up to 135: past that a plate bent over a
# few cm looks the same.
MAX_CREASE_DEG = 160.0
MAX_ROUNDED_DEG = 135.0
# A face is only as long as the stretch its points fill with gaps of at most this.
MAX_FACE_SPACING_M = 0.004
# Points of the outline drawn along a curved face.
OUTLINE_SAMPLES = 8


def fit(profile: SortedProfile) -> ProfileFit | NoFit:
    """The inside corner in a profile, or why there is none: of faces that may curve
    meeting at a crease (_curved_faces), else of two straight faces over the whole sides (a valley
    rounded at its bottom: _straight_faces)."""
    u, w, params = profile.u, profile.w, profile.params
    reasons = []
    for faces_of, max_included_deg in ((_curved_faces, MAX_CREASE_DEG), (_straight_faces, MAX_ROUNDED_DEG)):
        found = faces_of(u, w)
        fitted = found if isinstance(found, NoFit) else _corner_fit(*found, max_included_deg, params)
        if isinstance(fitted, ProfileFit):
            return fitted
        reasons.append(fitted.reason)
    return NoFit(reasons[0])


def _curved_faces(u, w):
    """(corner (u, w), left face, right face, rms error) of faces that may curve, split where a
    parabola on each side fits best and fitted again from the corner they meet at (the split can
    lie a few mm off a shallow corner, and a curved face is fitted near its start); or why not."""
    split = best_break(u, w)
    if split is None:
        return NoFit("too few points for two faces")
    found = _corner(u, w, split.index, (split.u, split.w))
    if isinstance(found, NoFit):
        return found
    found = _corner(u, w, int(np.searchsorted(u, found[0][0])), found[0])
    return found if isinstance(found, NoFit) else (*found, float(np.sqrt(split.error / len(u))))


def _corner(u, w, index: int, start):
    """((corner_u, corner_w), left face, right face) of the profile split before `index`, both
    faces fitted from `start` (u, w); or why there is none."""
    if min(index, len(u) - index) < MIN_FACE_POINTS:
        return NoFit("too few points for two faces")
    left = fit_face(u[:index], w[:index], start, -1.0)
    right = None if left is None else fit_face(u[index:], w[index:], start, 1.0)
    if right is None:
        return NoFit("a face is neither straight nor smoothly curved")
    corner_u = meeting_point(left, right, start[0])
    if corner_u is None or not (u[0] <= corner_u <= u[-1]):
        return NoFit("the two faces do not meet")
    return (corner_u, float(left.at(corner_u))), left, right


def _straight_faces(u, w):
    """(corner (u, w), left face, right face, rms error) of a straight face on each side of the
    split where two lines fit best (faces.straight_faces); or why not."""
    found = straight_faces(u, w)
    if isinstance(found, str):
        return NoFit(found)
    left, right, error = found
    corner_u = meeting_point(left, right, float(left.u.max()))
    if corner_u is None or not (u[0] <= corner_u <= u[-1]):
        return NoFit("the two faces do not meet")
    return (corner_u, float(left.at(corner_u))), left, right, error


def _corner_fit(
    corner, left: Face, right: Face, error_m: float, max_included_deg: float, params: JointsConfig
) -> ProfileFit | NoFit:
    """The fillet of two faces meeting at `corner` (u, w) at most `max_included_deg` apart, or why
    they are none."""
    corner_u, corner_w = corner
    to_left, to_right = left.tangent(corner_u), right.tangent(corner_u)
    if not (to_left[1] > 0 and to_right[1] > 0):
        return NoFit("the two faces do not form a concave corner")  # both must rise away from it
    included = float(np.degrees(np.arccos(np.clip(to_left @ to_right, -1.0, 1.0))))
    if not (MIN_INCLUDED_DEG <= included <= max_included_deg):
        return NoFit(f"the faces' included angle is outside {MIN_INCLUDED_DEG:g}-{max_included_deg:g} degrees")
    # No face curves tighter than MIN_FACE_RADIUS_M: the crease is then clearly sharper than the
    # faces' own bend (past MAX_CREASE_DEG it turns the tangent by 20 degrees at a point, where a
    # face turns by at most 8.6 degrees over 3 mm).
    if min(left.min_radius_m(), right.min_radius_m()) < MIN_FACE_RADIUS_M:
        return NoFit("a face curves tighter than joints' faces do (it turns over an edge of its own)")
    # Each face must really be there: its points spread at least a leg along the face, and
    # are dense enough to fill it (a few noisy points beside a hole make a steep "face"
    # whose u-extent times its slope looks long).
    corner = np.array([corner_u, corner_w])
    leg_left, leg_right = _face_extent(left, corner, to_left), _face_extent(right, corner, to_right)
    if min(leg_left, leg_right) < params.fillet_min_leg_m:
        return NoFit("a face is shorter than joints.fillet_min_leg_m")
    axis = -unit(to_left + to_right)
    geometry = JointGeometry(included_deg=included, legs_m=(leg_left, leg_right))
    outline = (*_face_outline(left, corner_u)[::-1], corner, *_face_outline(right, corner_u))
    return ProfileFit(KIND, float(corner_u), float(corner_w), float(axis[0]), float(axis[1]), error_m, geometry,
                      tuple((float(a), float(b)) for a, b in outline))  # fmt: skip


def _face_extent(face: Face, corner: np.ndarray, direction: np.ndarray) -> float:
    """How far a face reaches from the corner along `direction`, counting only the stretch out to
    its end that its points fill with gaps of at most MAX_FACE_SPACING_M."""
    along = np.sort((face.points() - corner) @ direction)
    gaps = np.flatnonzero(np.diff(along) > MAX_FACE_SPACING_M)
    start = along[gaps[-1] + 1] if len(gaps) else along[0]
    return float(along[-1] - max(start, 0.0)) if along[-1] > 0 else 0.0


def _face_outline(face: Face, corner_u: float) -> list[np.ndarray]:
    """Vertices along a face away from the corner, the last one 1 m out along its end tangent
    (the outline's end segment runs on as a ray): a straight face is that ray alone, a curved one
    is sampled out to its farthest point first."""
    if not face.curved:
        return [np.array([corner_u, face.at(corner_u)]) + face.tangent(corner_u)]
    far = float(face.u.max() if face.side > 0 else face.u.min())
    samples = np.linspace(corner_u, far, OUTLINE_SAMPLES + 1)[1:]
    vertices = list(np.column_stack([samples, face.at(samples)]))
    return vertices + [np.array([far, face.at(far)]) + face.tangent(far)]
