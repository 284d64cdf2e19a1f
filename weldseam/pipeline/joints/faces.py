"""The faces of a corner in a profile: where the profile breaks into two faces, each face as a
line or, where it is curved, a parabola, and where two faces meet.

u (m) lateral, w (m) height out of the work, u ascending, as every joint model receives them. A
face is a function w(u) fitted by least squares in w: the depth noise runs along the line of
sight, close to w, and a fit that takes noise across the face's own normal instead leans a face
toward w (by ~1 degree at 1 mm of noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.geometry import unit
from weldseam.pipeline.joints.robust import (
    fraction, least_squares_3, line, mean, noise, parabola, parabola_at, quantile,
)

# A break leaves at least this many points on each side.
MIN_FACE_POINTS = 5
# A face is curved when a parabola explains its points this much better than a line does:
# F = (SSE_line - SSE_parabola) / (SSE_parabola / (n - 3)), the 1-degree-of-freedom F statistic
# (16: four standard deviations of the curvature's estimate).
CURVED_F = 16.0
# A curved face is fitted within this distance of the break: a parabola stays within 0.05 mm of
# an arc of 25 mm radius over it (x^4 / 8 R^3), and the farther points would bend its tangent.
CURVED_REACH_M = 0.016
# A face curves no tighter than this (a pipe's or a tube's flank); tighter, it turns over an edge
# of its own (a groove's wall and the plate beside it).
MIN_FACE_RADIUS_M = 0.02
# A point farther from its face than max(3 x the face's robust noise, this) is not on it; a face
# with fewer than INLIER_FRACTION of its side's points on it is no face.
MIN_INLIER_BAND_M = 0.0005
INLIER_FRACTION = 0.8


@dataclass(frozen=True)
class Break:
    """Where a profile splits into two faces: the index of the first point of the right face, its
    (u, w) (m), and the total squared error (m^2) of the parabolas fitted on both sides."""

    index: int
    u: float
    w: float
    error: float


@dataclass(frozen=True)
class Face:
    """One face: w = c0 + c1 t + c2 t^2 with t = u - origin_u (c2 = 0 for a straight face), on
    the `side` of the corner it lies (-1 left, +1 right), and the u (N,) of its points."""

    coefficients: tuple[float, float, float]
    origin_u: float
    side: float
    u: np.ndarray
    curved: bool

    def at(self, u):
        """Height (m) of the face at `u` (a number or an array)."""
        c0, c1, c2 = self.coefficients
        t = np.asarray(u, dtype=np.float64) - self.origin_u
        return c0 + c1 * t + c2 * t * t

    def slope(self, u: float) -> float:
        """dw/du of the face at `u`."""
        _, c1, c2 = self.coefficients
        return float(c1 + 2.0 * c2 * (u - self.origin_u))

    def tangent(self, u: float) -> np.ndarray:
        """Unit tangent (u, w) at `u`, pointing along the face away from the corner."""
        return unit(self.side * np.array([1.0, self.slope(u)]))

    def min_radius_m(self) -> float:
        """The tightest radius of curvature (m) over the face's points (inf for a straight face):
        (1 + w'^2)^1.5 / |w''| at the point of least |slope| (a parabola's vertex, if among them)."""
        bend = abs(2.0 * self.coefficients[2])
        if bend == 0:
            return float("inf")
        vertex = self.origin_u - self.coefficients[1] / (2.0 * self.coefficients[2])
        flattest = float(np.clip(vertex, self.u.min(), self.u.max()))
        return float(np.hypot(1.0, self.slope(flattest)) ** 3 / bend)

    def points(self) -> np.ndarray:
        """The face's points moved onto it (N, 2)."""
        return np.column_stack([self.u, self.at(self.u)])


def best_break(u: np.ndarray, w: np.ndarray) -> Break | None:
    """The split minimising the total squared error of a least-squares parabola w(u) on each side
    (from running sums of the monomials, every split at once), or None with too few points."""
    n = len(u)
    splits = np.arange(MIN_FACE_POINTS, n - MIN_FACE_POINTS + 1)
    if len(splits) == 0:
        return None
    # Monomials of u centred and scaled to [-1, 1], so the normal equations stay well conditioned.
    centre, scale = (u[0] + u[-1]) / 2, max((u[-1] - u[0]) / 2, 1e-9)
    x = (u - centre) / scale
    x2 = x * x
    columns = [np.ones(n), x, x2, x2 * x, x2 * x2, w, x * w, x2 * w, w * w]
    sums = np.cumsum(np.column_stack(columns), axis=0)
    left = sums[splits - 1]
    both = _parabola_error(np.concatenate([left, sums[-1] - left]))  # one batch: each row solved alone
    error = both[: len(splits)] + both[len(splits) :]
    best = int(np.argmin(error))
    index = int(splits[best])
    return Break(index, float(u[index]), float(w[index]), float(max(error[best], 0.0)))


def fit_face(u: np.ndarray, w: np.ndarray, origin: tuple[float, float], side: float) -> Face | None:
    """The points of one side (-1 left, +1 right) of a break at `origin` (u, w) as a face; None
    when too few of them lie on a line or parabola: a robust parabola; on its inliers a line,
    unless the parabola is significantly better (CURVED_F); a curved face is then fitted again
    within CURVED_REACH_M of the origin."""
    origin_u, origin_w = origin
    if not smooth_side(u, w, origin):
        return None
    t = u - origin_u
    residual = w - parabola_at(parabola(t, w), t)
    inliers = np.abs(residual) <= max(3 * noise(residual), MIN_INLIER_BAND_M)
    count = np.count_nonzero(inliers)
    if fraction(inliers) < INLIER_FRACTION or count < MIN_FACE_POINTS:
        return None
    if not curved(t[inliers], w[inliers])[0]:
        return _straight_face(t, w, origin_u, side)
    near = inliers & (np.hypot(t, w - origin_w) <= CURVED_REACH_M)
    if np.count_nonzero(near) < MIN_FACE_POINTS:
        return None
    coefficients = tuple(float(c) for c in parabola(t[near], w[near]))
    return Face(coefficients, origin_u, side, u[near], True)


def smooth_side(u: np.ndarray, w: np.ndarray, origin: tuple[float, float]) -> bool:
    """Whether a side's points (u ascending), from a break at `origin` (u, w), make one smooth
    face: a line, or a circular arc of at least MIN_FACE_RADIUS_M (a pipe or a tube seen across),
    fitted to the points within CURVED_REACH_M of the break, leaves INLIER_FRACTION of all of them
    within max(3 x the robust noise of the near points about it, MIN_INLIER_BAND_M). Fitted near
    the break, the face cannot bend round a kink farther out (a groove's wall turning onto the
    plate over a rounded edge), and the band is the face's own noise, not the misfit's spread."""
    near = np.hypot(u - origin[0], w - origin[1]) <= CURVED_REACH_M
    if np.count_nonzero(near) < MIN_FACE_POINTS:
        return False
    intercept, slope = line(u[near], w[near])
    distance = (w - intercept - slope * u) / np.hypot(1.0, slope)
    if _on_face(distance, near):
        return True
    circle = _circle(u[near], w[near])
    if circle is None or circle[2] < MIN_FACE_RADIUS_M:
        return False
    centre_u, centre_w, radius = circle
    return _on_face(np.hypot(u - centre_u, w - centre_w) - radius, near)


def _on_face(distance: np.ndarray, near: np.ndarray) -> bool:
    """Whether INLIER_FRACTION of the signed distances (m) to a face lie within max(3 x the robust
    noise of the `near` ones, MIN_INLIER_BAND_M)."""
    band = max(3 * noise(distance[near]), MIN_INLIER_BAND_M)
    return bool(quantile(np.abs(distance), INLIER_FRACTION) <= band)


def _circle(u: np.ndarray, w: np.ndarray, iterations: int = 4) -> tuple[float, float, float] | None:
    """(centre u, centre w, radius) of the circle nearest the points: the algebraic circle
    u^2 + w^2 + D u + E w + F = 0 (Kasa; its radius is short on a short noisy arc), then Gauss-Newton
    steps on the geometric distances; None where the points lie on a line."""
    ones = np.ones_like(u)
    d, e, f = least_squares_3((u, w, ones), -(u * u + w * w))
    centre = np.array([-d / 2, -e / 2])
    radius = np.sqrt(max(centre @ centre - f, 0.0))
    for _ in range(iterations):
        offset_u, offset_w = u - centre[0], w - centre[1]
        reach = np.hypot(offset_u, offset_w)
        if not np.all(reach > 0):
            return None
        step = least_squares_3((-offset_u / reach, -offset_w / reach, -ones), radius - reach)
        centre, radius = centre + step[:2], radius + step[2]
    return (float(centre[0]), float(centre[1]), float(abs(radius))) if np.isfinite(radius) else None


def _straight_face(t, w, origin_u: float, side: float) -> Face | None:
    """A straight face through the points (t = u - origin_u, w): a robust line fitted again to its
    inliers (line_inliers)."""
    inliers = line_inliers(t, w)
    if inliers is None:
        return None
    intercept, slope = line(t[inliers], w[inliers])
    return Face((intercept, slope, 0.0), origin_u, side, t[inliers] + origin_u, False)


def line_inliers(t, w) -> np.ndarray | None:
    """Which points (N,) lie on a robust line through them (the points a corner's rounding or a
    mixed pixel moves off it do not), or None when too few do."""
    intercept, slope = line(t, w)
    residual = w - intercept - slope * t
    inliers = np.abs(residual) <= max(3 * noise(residual), MIN_INLIER_BAND_M)
    if fraction(inliers) < INLIER_FRACTION or np.count_nonzero(inliers) < MIN_FACE_POINTS:
        return None
    return inliers


def straight_faces(u: np.ndarray, w: np.ndarray) -> tuple[Face, Face, float] | str:
    """(left face, right face, rms error (m)) of two straight faces: the lines on either side of
    the split minimising their total squared error in w (prefix sums, every split at once), each
    fitted again to its inliers (INLIER_FRACTION of its side within max(3 sigma,
    MIN_INLIER_BAND_M)); or why there are none. A side that bends away from the open corner
    (its parabola's w'' significantly negative: CURVED_F) turns over an edge of its own (a groove's
    wall onto the plate): no face."""
    n = len(u)
    splits = np.arange(MIN_FACE_POINTS, n - MIN_FACE_POINTS + 1)
    if len(splits) == 0:
        return "too few points for two faces"
    sums = np.cumsum(np.column_stack([np.ones(n), u, w, u * u, u * w, w * w]), axis=0)
    left_sums = sums[splits - 1]
    error = line_sse(left_sums) + line_sse(sums[-1] - left_sums)
    best = int(np.argmin(error))
    split = int(splits[best])
    faces = []
    for part, side in ((slice(0, split), -1.0), (slice(split, n), 1.0)):
        pu, pw = u[part], w[part]
        inliers = line_inliers(pu, pw)
        if inliers is None:
            return "a face is not a straight line"
        if _bends_away(pu[inliers], pw[inliers]):
            return "a face turns over an edge of its own"
        intercept, slope = line(pu[inliers], pw[inliers])
        faces.append(Face((intercept, slope, 0.0), 0.0, side, pu[inliers], False))
    return faces[0], faces[1], float(np.sqrt(max(error[best], 0.0) / n))


def line_sse(sums: np.ndarray) -> np.ndarray:
    """Residual sum of squares of the least-squares line w(u) through each segment, from its sums
    (rows: 1, u, w, u^2, uw, w^2)."""
    count, su, sw, suu, suw, sww = sums.T
    var_u, cov, var_w = suu - su * su / count, suw - su * sw / count, sww - sw * sw / count
    return var_w - np.divide(cov * cov, var_u, out=np.zeros_like(cov), where=var_u > 1e-12)


def _bends_away(u: np.ndarray, w: np.ndarray) -> bool:
    """Whether points (u, w) bend significantly away from the open side (w up): a parabola's w''
    below zero, explaining them CURVED_F better than a line."""
    significant, curve = curved(u, w)
    return bool(significant and curve[2] < 0)


def curved(u: np.ndarray, w: np.ndarray) -> tuple[bool, np.ndarray]:
    """Whether a parabola explains points (u, w) significantly better than a line, F =
    (SSE_line - SSE_parabola) / (SSE_parabola / (n - 3)) over CURVED_F, and the parabola's
    (c0, c1, c2) in u - mean(u)."""
    intercept, slope = line(u, w)
    off_line = w - intercept - slope * u
    centred = u - mean(u)
    curve = parabola(centred, w)
    off_curve = w - parabola_at(curve, centred)
    line_error, curve_error = float(off_line @ off_line), float(off_curve @ off_curve)
    return (line_error - curve_error) * (len(u) - 3) > CURVED_F * max(curve_error, 1e-18), curve


def meeting_point(left: Face, right: Face, start_u: float, iterations: int = 6) -> float | None:
    """The u where two faces meet, by Newton's method on left(u) - right(u) from `start_u`; None
    where they run parallel there."""
    u = start_u
    for _ in range(iterations):
        rate = left.slope(u) - right.slope(u)
        if abs(rate) < 1e-6:
            return None
        u -= float(left.at(u) - right.at(u)) / rate
    return u


def _parabola_error(sums: np.ndarray) -> np.ndarray:
    """Residual sum of squares of the least-squares parabola through each segment, from its sums
    (rows: 1, x, x^2, x^3, x^4, w, xw, x^2w, w^2): sum w^2 - b^T A^-1 b (normal equations A c = b)."""
    # normal[:, i, j] = sum of x^(i + j) (columns 0-4 of the sums); b = sums of w, x w, x^2 w.
    normal = sums[:, np.add.outer(np.arange(3), np.arange(3))]
    normal += np.eye(3) * (1e-12 * sums[:, 0])[:, None, None]  # a segment whose points share one u
    b = sums[:, 5:8]
    return sums[:, 8] - np.einsum("ij,ij->i", b, np.linalg.solve(normal, b[..., None])[..., 0])
