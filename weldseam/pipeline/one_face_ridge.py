"""An outside corner with one face unseen: a box's edge seen from one side.

Two plates meeting at a convex edge, each edge bevelled so they leave an open V (the outside
corner model), slope away from the ridge on either side. A camera that sees one face squarely sees
the other at a grazing angle or from behind, past the sensor's incidence limit: a section holds the
seen face A up to the V's edge E_A, then the far wall of the V (it faces the camera across the
opening), and of the far face B at most a few points. The outside corner model needs both faces.

Plates meeting at an outside corner stand square to each other (boxes, frames, brackets), and a
face the camera would see squarely would have been measured. So face B is taken square to A:
its outward normal is A's direction a toward the V, the corner's outward bisector
c = (n_A + a) / sqrt 2 (n_A: A's outward normal), and the V's opening runs from E_A along
e = (a - n_A) / sqrt 2, square to c. The far wall B is the line through the points beyond E_A
below that opening line, and its top edge E_B where the line meets the opening line. The seam is
the opening's middle (E_A + E_B) / 2, the torch axis -c, as the outside corner model places them;
the fit records one face seen (JointGeometry.faces_seen = 1) and no measured included angle.

What is not such a corner: where points stand above the opening line beyond E_A (a plate going on
level beyond a groove, a wall rising at an inside corner), where face B would face the camera
(then it would have been seen), where no wall rises from a V at least groove_min_depth_m deep to the
opening line, or the wall leans outside WALL_MIN_DEG-WALL_MAX_DEG off the bisector.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from weldseam.config import JointsConfig
from weldseam.geometry import unit
from weldseam.pipeline.joints import JointGeometry, JointKind, ProfileFit
from weldseam.pipeline.joints.outside_corner import (
    EDGE_SIGMAS, MAX_OPENING_M, MIN_EDGE_BAND_M, MIN_OPENING_M, SURFACE_BAND_M,
)
from weldseam.pipeline.joints.robust import line, middle, noise
from weldseam.pipeline.one_face import OBLIQUE_COS

KIND = JointKind.OUTSIDE_CORNER
# The fewest points a line (the seen face, the far wall) is fitted to.
MIN_LINE_POINTS = 5
# The seen face: straight (FACE_INLIERS of the points up to its end within max(3 sigma,
# SURFACE_BAND_M) of its line, the outside corner model's band), this long from its first point to
# its end; its points' runs are split at gaps over FACE_GAP_M.
MIN_FACE_M = 0.012
FACE_INLIERS = 0.8
FACE_GAP_M = 0.002
# The face ends at the end of its last run of points (gaps under FACE_GAP_M) this long: a few
# points of the far wall's top within the face's band beyond the V are no face.
MIN_RUN_M = 0.003
# The face ends at its last point within max(EDGE_SIGMAS sigma, MIN_EDGE_BAND_M) of its line, and
# the V's opening lies within MIN_OPENING_M-MAX_OPENING_M, as in the outside corner model; the
# unseen face B is seen at more than 70 degrees of incidence (OBLIQUE_COS), or from behind, as in
# one_face.
# The far wall: at least MIN_LINE_POINTS on its line (within max(3 sigma, WALL_BAND_M)), this
# share of those beyond E_A within MAX_OPENING_M, its top within max(3 sigma, TOP_BAND_M) of the
# opening line (a surface going on past it is no wall ending at an edge), leaning WALL_MIN_DEG-
# WALL_MAX_DEG off the bisector toward face B: a V of 10-80 degrees cut about the bisector (its
# walls measured 6-35 degrees off it on broad outside corners). A wall leaning 45 degrees runs
# parallel to face A: a lower surface going on past A's end (the table beyond a thick plate's
# edge, measured 43-45 degrees) shows the same, so an open corner's 90-degree V is not taken so.
WALL_INLIERS = 0.6
WALL_BAND_M = 0.0005
TOP_BAND_M = 0.001
WALL_MIN_DEG = 5.0
WALL_MAX_DEG = 40.0
# The far wall's points lie no nearer E_A than the opening's middle less max(3 sigma, this) (a root
# gap's edge, a mixed pixel at the root).
ROOT_SLACK_M = 0.001
# Nothing stands above the opening line beyond E_A: no point farther above it than max(3 sigma,
# ABOVE_BAND_M) (beyond E_B face B falls away from it).
ABOVE_BAND_M = 0.0012


class SeenFace(NamedTuple):
    """The seen face: its line w = intercept + slope u, the u (m) where it ends toward the V, its
    robust noise sigma (m) and the median distance of its points from the line (m)."""

    intercept: float
    slope: float
    end_u: float
    sigma: float
    residual_m: float


def one_face_ridge(u: np.ndarray, w: np.ndarray, toward, params: JointsConfig, half_width_m: float) -> ProfileFit | None:
    """The outside corner of a profile (u ascending, m; the window |u|, |w| <= half_width_m) whose
    face beyond the V is unseen, or None. `toward`: (u, w) of the unit direction toward the camera
    in the section plane. The V beside the seen face's end nearest the section's centre wins where
    both sides qualify."""
    found = [fit for fit in (_ridge(u, w, toward, params, half_width_m), _mirrored(u, w, toward, params, half_width_m))
             if fit is not None]  # fmt: skip
    return min(found, key=lambda fit: abs(fit.u)) if found else None


def _mirrored(u, w, toward, params: JointsConfig, half_width_m: float) -> ProfileFit | None:
    """_ridge of the profile mirrored across u = 0 (the seen face on the right), mirrored back."""
    fit = _ridge(-u[::-1], w[::-1], (-toward[0], toward[1]), params, half_width_m)
    if fit is None:
        return None
    outline = tuple((-a, b) for a, b in fit.outline[::-1])
    return ProfileFit(fit.kind, -fit.u, fit.w, -fit.axis_u, fit.axis_w, fit.residual_m, fit.geometry, outline)


def _ridge(u, w, toward, params: JointsConfig, half_width_m: float) -> ProfileFit | None:
    """The corner whose seen face A lies left of the V (A's end toward larger u), or None."""
    if len(u) < 2 * MIN_LINE_POINTS:
        return None
    face = _seen_face(u, w)
    if face is None:
        return None
    a = unit(np.array([1.0, face.slope]))  # along A toward the V: face B's outward normal
    normal = np.array([-a[1], a[0]])  # A's outward normal (w up)
    if normal @ toward <= 0 or a @ toward > OBLIQUE_COS:
        return None  # A seen from behind, or B would face the camera
    bisector, opening = unit(normal + a), unit(a - normal)
    edge_a = np.array([face.end_u, face.intercept + face.slope * face.end_u])
    offsets = np.column_stack([u, w]) - edge_a
    across, up = offsets @ opening, offsets @ bisector
    beyond = across > 0
    if np.any(beyond & (up > max(3 * face.sigma, ABOVE_BAND_M))):
        return None  # a surface going on beyond the V, or a wall rising: no convex edge
    beyond &= across <= MAX_OPENING_M
    wall = _far_wall(across[beyond], up[beyond], face.sigma, params)
    if wall is None:
        return None
    width_m, depth_m = wall
    if not MIN_OPENING_M <= width_m <= MAX_OPENING_M:
        return None
    seam = edge_a + opening * width_m / 2
    edge_b = edge_a + opening * width_m
    # The window must show what lies past the far edge (whether a surface goes on above the opening
    # line there): a "far edge" near its rim may be a surface running out of it.
    if np.abs(edge_b).max() > half_width_m - MAX_OPENING_M / 2:
        return None
    geometry = JointGeometry(opening_m=float(width_m), depth_m=float(depth_m), faces_seen=1)
    outline = (edge_a - a, edge_a, seam - bisector * depth_m, edge_b, edge_b - normal)
    return ProfileFit(KIND, float(seam[0]), float(seam[1]), float(-bisector[0]), float(-bisector[1]), face.residual_m,
                      geometry, tuple((float(p), float(q)) for p, q in outline))  # fmt: skip


def _seen_face(u, w) -> SeenFace | None:
    """The seen face, or None where it is not straight or too short: a robust line started from the
    left half of the points; its end is that of its last run of inliers (gaps under FACE_GAP_M) at
    least MIN_RUN_M long, the face from its first inlier to there at least MIN_FACE_M long with
    FACE_INLIERS of the points on it; the line refitted to those, and the end placed half a point
    spacing past its last point within its own noise (a hidden wall's edge lies there)."""
    inliers = u <= middle(u)
    for _ in range(3):
        if np.count_nonzero(inliers) < MIN_LINE_POINTS:
            return None
        intercept, slope = line(u[inliers], w[inliers])
        residual = w - (intercept + slope * u)
        sigma = noise(residual[inliers])
        inliers = np.abs(residual) <= max(3 * sigma, SURFACE_BAND_M)
    on = np.flatnonzero(inliers)
    if len(on) == 0:
        return None
    runs = np.split(on, np.flatnonzero(np.diff(u[on]) > FACE_GAP_M) + 1)
    run = next((run for run in runs[::-1] if u[run[-1]] - u[run[0]] >= MIN_RUN_M), None)
    if run is None:
        return None
    last = run[-1]
    if u[last] - u[on[0]] < MIN_FACE_M or np.count_nonzero(inliers[: last + 1]) < FACE_INLIERS * (last + 1):
        return None
    run = on[on <= last]
    intercept, slope = line(u[run], w[run])
    residual = w[run] - (intercept + slope * u[run])
    sigma = noise(residual)
    # It ends at its last point within its own noise of its line: the top of a grazing wall beyond
    # its edge, smeared along the line of sight, lies within the wider band.
    run = run[np.abs(residual) <= max(EDGE_SIGMAS * sigma, MIN_EDGE_BAND_M)]
    if len(run) == 0:
        return None
    spacing = middle(np.diff(u[run])[-5:]) if len(run) > 1 else 0.0
    return SeenFace(intercept, slope, float(u[run[-1]] + spacing / 2), sigma, middle(np.abs(residual)))


def _far_wall(across, up, sigma: float, params: JointsConfig) -> tuple[float, float] | None:
    """(opening width, depth) (m) of the V's far wall among the points beyond E_A (`across` the
    opening from E_A, `up` along the bisector from it): the robust line across = k0 + k1 up
    through them, rising toward face B (leaning WALL_MIN_DEG-WALL_MAX_DEG off the bisector) from a
    V at least groove_min_depth_m deep up to the opening line (within max(3 sigma, TOP_BAND_M)),
    meets it at E_B (up = 0: across = k0). None where no such wall is seen. Face B's own few points
    at grazing incidence are no substitute: a plate's square edge, rounded, shows the same."""
    if len(across) < MIN_LINE_POINTS:
        return None
    band = max(3 * sigma, WALL_BAND_M)
    inliers = np.ones(len(across), bool)
    for _ in range(3):
        if np.count_nonzero(inliers) < MIN_LINE_POINTS:
            return None
        k0, k1 = line(up[inliers], across[inliers])
        inliers = np.abs(across - (k0 + k1 * up)) <= band
    count = np.count_nonzero(inliers)
    if count < MIN_LINE_POINTS or count < WALL_INLIERS * len(across):
        return None
    lean = np.degrees(np.arctan(k1))  # the wall runs toward face B as it rises
    top, bottom = up[inliers].max(), up[inliers].min()
    if not (WALL_MIN_DEG <= lean <= WALL_MAX_DEG and abs(top) <= max(3 * sigma, TOP_BAND_M)
            and -bottom >= params.groove_min_depth_m):
        return None
    # The V is cut about the bisector: its far wall lies in its far half, from the root (under the
    # opening's middle) up to E_B. A surface reaching back under E_A is a lower one going on beyond
    # the face's end (the table past a plate's edge), however its slope lies.
    if across[inliers].min() < k0 / 2 - max(3 * sigma, ROOT_SLACK_M):
        return None
    return float(k0), float(-bottom)
