"""An inside corner with one face unseen, that face carried on from where both were seen.

Toward the ends of a seam the camera often sees one face of an inside corner at grazing
incidence: a saddle's branch pipe near its silhouette, a standing pipe's wall on its flank. A
section there holds the other face up to the corner and nothing of this one. one_face places
such a wall only square to the seen face and with its top in sight; a saddle's corner opens to
110-130 degrees there. The sections before, where both faces were seen, say where the face goes:
plates and pipes are ruled surfaces, and along a seam the tangent planes of one face share a
direction, its ruling (a pipe's axis; in a plate, any line of it).

Each full fit gives a face's direction d across its section (from the torch axis, the bisector,
and the included angle) and so the face's normal n = d x t (t the travel). The ruling r is the
direction most nearly perpendicular to the normals of the latest fits (their least singular
vector) where they turn round it (a pipe); where they do not (a plate), the face's latest
direction. In a section ahead the face runs from the corner along r made perpendicular to the
travel, which says nothing where r runs almost along the seam.

The corner is where the seen face ends toward the unseen one, turning into the carried direction,
the torch axis the bisector of the two. The unseen face is one the camera did not measure: seen at
grazing incidence or edge-on, or facing it but lost in a dropout or in the stereo shadow a
structured-light or stereo sensor casts beside a wall (its second view, a baseline away, does not
see the foot); the seen face still runs up to the corner. It must not be seen from behind: then it
would hide the seen face's end, which is the edge of its shadow. The fit records one face seen.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.config import JointsConfig
from weldseam.geometry import unit
from weldseam.pipeline.joints import MIN_PROFILE_POINTS, JointGeometry, JointKind, ProfileFit
from weldseam.pipeline.joints.faces import line_inliers
from weldseam.pipeline.joints.robust import line, parabola, parabola_at
from weldseam.pipeline.one_face import EDGE_ON_COS, GAP_M
from weldseam.pipeline.section import FineSurface, SectionFit, section_frame

CORNER = JointKind.FILLET
# Fewer full fits than this say too little of how a face turns.
MIN_FITS = 4
# The normals turn round a ruling when their second singular value is this share of the first
# (over ~15 degrees; noise turns a plane's normals by a degree or two) and this many times the
# third (they turn round one direction, not every way).
MIN_TURN = 0.1
RULED_RATIO = 3.0
# A ruling within asin(0.5) = 30 degrees of the travel says little of the face's direction across
# the section.
MIN_ACROSS = 0.5
# The faces' included angle, as the fillet model takes it.
MIN_INCLUDED_DEG = 45.0
MAX_INCLUDED_DEG = 160.0


@dataclass(frozen=True)
class CornerTemplate:
    """The rulings (3,) of a corner's faces left (-lateral) and right of the seam, each a unit
    vector pointing away from the corner."""

    left: np.ndarray
    right: np.ndarray


def corner_template(fits: list[SectionFit], travel: np.ndarray) -> CornerTemplate | None:
    """The rulings of the faces of full corner fits (`fits`, both faces seen, with their
    `travel` (K, 3)), or None with fewer than MIN_FITS of them."""
    normals: dict[int, list] = {-1: [], 1: []}
    latest: dict[int, np.ndarray] = {}
    for fit, along in zip(fits, travel):
        if not full_corner(fit):
            continue
        half = np.radians(fit.geometry.included_deg) / 2
        lateral = unit(np.cross(along, fit.torch_axis))
        for side in (-1, 1):
            direction = unit(-np.cos(half) * fit.torch_axis + side * np.sin(half) * lateral)
            normals[side].append(unit(np.cross(direction, along)))
            latest[side] = direction
    if len(normals[1]) < MIN_FITS:
        return None
    return CornerTemplate(*(_ruling(np.array(normals[side]), latest[side]) for side in (-1, 1)))


def full_corner(fit: SectionFit) -> bool:
    """Whether `fit` is a corner fitted with both faces seen and its included angle measured."""
    return fit.kind == CORNER and not fit.flags and fit.geometry.included_deg is not None


def _ruling(normals: np.ndarray, latest: np.ndarray) -> np.ndarray:
    """The direction most nearly perpendicular to a face's `normals` (K, 3) where they turn round
    it (MIN_TURN, RULED_RATIO), else the face's `latest` direction; pointing as that does."""
    _, singular, rows = np.linalg.svd(normals, full_matrices=False)
    if singular[1] <= MIN_TURN * singular[0] or singular[1] <= RULED_RATIO * singular[2]:
        return latest
    ruling = rows[2]
    return ruling if ruling @ latest >= 0 else -ruling


def _break(points: np.ndarray, on_face: np.ndarray, along_face: np.ndarray, unseen: np.ndarray):
    """Where a seen face (the line through `on_face` along `along_face`, pointing back into it)
    turns into the unseen face's direction: of the points (K, 2) of its end, those past the corner
    may lie on the unseen face (its foot, at grazing incidence). The corner on the line, at one of
    the points' feet, minimising the squared distances of the points before it to the seen face
    and of those past it to the unseen face's line through it."""
    reach = (points - on_face) @ along_face  # along the seen face, back into it
    feet = on_face + reach[:, None] * along_face
    across_seen = (points - on_face) @ np.array([-along_face[1], along_face[0]])
    # offsets[c, k]: point k from the corner at foot c, across the unseen face's direction.
    offsets = points[None, :, :] - feet[:, None, :]
    across_unseen = offsets[..., 0] * unseen[1] - offsets[..., 1] * unseen[0]
    past = reach[None, :] < reach[:, None]
    cost = np.where(past, across_unseen**2, across_seen[None, :] ** 2).sum(axis=1)
    best = int(np.argmin(cost))
    return feet[best], ~past[best]


def carried_fit(surface: FineSurface, centre, travel, axis, template: CornerTemplate) -> SectionFit:
    """The section at `centre` across `travel` fitted as a corner whose face not seen runs along
    its ruling in `template` (carried_corner); no fit without a single camera."""
    axis, lateral = section_frame(travel, axis)
    profile = surface.profile(centre, travel, axis, lateral)
    toward = surface.toward(profile)
    if toward is None:
        return profile.to_3d(None, reason="no single camera to tell an unseen face from a dropout")
    faces = {}
    for side, ruling in ((-1, template.left), (1, template.right)):
        across = ruling - (ruling @ travel) * travel
        if np.linalg.norm(across) >= MIN_ACROSS:
            faces[side] = unit(np.array([across @ lateral, -(across @ axis)]))
    order = np.argsort(profile.u, kind="stable")
    found = carried_corner(profile.u[order], profile.w[order], faces, np.array(toward),
                           surface.params.joints, surface.params.half_width_m)  # fmt: skip
    if found is None:
        return profile.to_3d(None, reason="no face ends where the carried face would meet it")
    return profile.to_3d(found)


def carried_corner(u, w, faces: dict[int, np.ndarray], toward, params: JointsConfig,
                   half_width_m: float) -> ProfileFit | None:
    """The corner of a profile (u ascending, m; the window |u| <= half_width_m) where a straight
    face ends at a gap in the points, or short of the window's edge, and the other face, unseen,
    runs on from it along faces[side] ((u, w) unit direction of the face on that side: -1 left, +1
    right; a side missing is not known), or None; of several, the one nearest the section's
    centre. `toward`: (u, w) unit direction toward the camera."""
    if len(u) < MIN_PROFILE_POINTS:
        return None
    runs = np.split(np.arange(len(u)), np.flatnonzero(np.diff(u) > GAP_M) + 1)
    found = []
    for unseen_side, unseen in faces.items():
        for run in runs:  # the seen face ends toward the unseen one's side
            end_u = u[run[-1] if unseen_side > 0 else run[0]]
            if half_width_m - abs(end_u) < GAP_M:
                continue  # the face runs out of the window
            corner = _corner(u[run], w[run], unseen_side, unseen, toward, params)
            if corner is not None:
                found.append(corner)
    return min(found, key=lambda fit: abs(fit.u)) if found else None


def _corner(u, w, unseen_side: int, unseen: np.ndarray, toward, params: JointsConfig) -> ProfileFit | None:
    """The corner at the end toward `unseen_side` of one run of points (a seen face), the unseen
    face running along `unseen` from it, or None. The seen face is taken over a fillet leg from its
    end and must reach that far: a line through it, the corner where it turns into the unseen
    face's direction (_break), and a parabola through the points before the corner for the
    corner's height and the face's tangent there (a pipe's face curves)."""
    end = np.array([u[-1], w[-1]] if unseen_side > 0 else [u[0], w[0]])
    reach = np.hypot(u - end[0], w - end[1])
    near = reach <= params.fillet_min_leg_m
    nu, nw = u[near], w[near]
    if len(nu) < 8 or reach[near].max() < 0.8 * params.fillet_min_leg_m:
        return None
    inliers = line_inliers(nu, nw)
    if inliers is None:
        return None
    points = np.column_stack([nu[inliers], nw[inliers]])
    intercept, slope = line(nu[inliers], nw[inliers])
    for _ in range(2):  # the break, then again from the face refitted to the points before it
        along_face = unit(np.array([-unseen_side, -unseen_side * slope]))  # from the end back into the seen face
        corner, before = _break(points, np.array([0.0, intercept]), along_face, unseen)
        if np.count_nonzero(before) < 8:
            return None
        intercept, slope = line(points[before, 0], points[before, 1])
    # A pipe's face curves: the corner and the face's tangent there from a parabola through the
    # points before it.
    offset = points[before, 0] - corner[0]
    curve = parabola(offset, points[before, 1])
    corner, slope = np.array([corner[0], curve[0]]), curve[1]
    along_face = unit(np.array([-unseen_side, -unseen_side * slope]))
    normal = unit(np.array([-slope, 1.0]))  # the seen face's normal, out of the work
    if normal @ toward <= 0:
        return None  # seen from behind: not a face of this part
    if normal @ unseen <= 0:
        return None  # the unseen face must rise out of the work from the corner (concave)
    included = float(np.degrees(np.arccos(np.clip(along_face @ unseen, -1.0, 1.0))))
    if not MIN_INCLUDED_DEG <= included <= MAX_INCLUDED_DEG:
        return None
    # The unseen face's normal, out of the work: toward the seen face's side of it.
    unseen_normal = np.array([-unseen[1], unseen[0]])
    unseen_normal = unseen_normal if unseen_normal @ along_face > 0 else -unseen_normal
    if unseen_normal @ toward < -EDGE_ON_COS:
        return None  # seen from behind: it would hide the seen face's end
    axis = -unit(along_face + unseen)
    geometry = JointGeometry(included_deg=included, legs_m=None, faces_seen=1)
    outline = (corner + along_face, corner, corner + unseen)
    residual_m = float(np.median(np.abs(points[before, 1] - parabola_at(curve, offset))))
    return ProfileFit(CORNER, float(corner[0]), float(corner[1]), float(axis[0]), float(axis[1]), residual_m,
                      geometry, tuple((float(a), float(b)) for a, b in outline))  # fmt: skip
