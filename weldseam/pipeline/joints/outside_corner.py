"""The outside corner model: two plates meeting at a convex edge, each edge bevelled so they leave an
open V along the ridge.

The profile is a roof: two straight faces sloping down away from a ridge (a break between two
lines, the break minimising the total squared error; each face refitted to the half of its points
farthest from the break), at an outer included angle of MIN_ROOF_DEG-MAX_ROOF_DEG, with a V notch
where they would meet. Each top edge of the V is where its wall turns off its face (a hinge fitted to
the points beside the edge), or, where the V shows no wall, where its face ends toward the ridge
(the camera sees a surface up to its edge); each face is then fitted again to its points outside
its edge, and its edge sought again from that line. Between the edges lies the V: its
points (if any are seen) at least `groove_min_depth_m` below the roof; a plain ridge, whose faces
run into each other, is no outside corner. The torch axis is minus the bisector of the two faces'
outward normals; the V is cut symmetrically about it, so the seam point (the midpoint of the two
top edges) lies on the bisector through the faces' apex, as deep below the apex as the two top
edges on average.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from weldseam.geometry import unit
from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit
from weldseam.pipeline.joints.faces import line_sse
from weldseam.pipeline.joints.profile import SortedProfile
from weldseam.pipeline.joints.robust import fraction, line, median, middle, noise, parabola, parabola_at, upper_decile

KIND = JointKind.OUTSIDE_CORNER
# Where the ridge lies does not depend on where the window sits.
CENTRED = False
# Two plates' corner runs their length; a shorter convex ridge is a part's or a loose bar's edge
# (a web's top edge, a clamp's jaw), which a dropout along it makes look like a hidden V.
MIN_LENGTH_M = 0.05
SPECIALISES = None
# The outer faces' included angle (degrees): plates at 90 degrees, give or take; flatter is a
# V-groove in one surface (180), or a pipe's curve.
MIN_ROOF_DEG = 60.0
MAX_ROOF_DEG = 140.0
# Each face runs at least this far from its edge, straight (MIN_INLIER_FRACTION of its side's
# points within max(3 sigma, SURFACE_BAND_M) of its line; 1 mm depth steps put a face on two
# levels).
MIN_FACE_M = 0.006
MIN_INLIER_FRACTION = 0.7
SURFACE_BAND_M = 0.0012
# A plate's face is flat: one bowing more than this over its extent (and than its noise) is a
# curved part's surface (a pipe seen across its silhouette), no plate (_curved).
MAX_SAGITTA_M = 0.001
# A face is only as long as the stretch its points fill from its edge with gaps of at most this.
MAX_FACE_SPACING_M = 0.002
# The V's opening at the surface (m): a wider gap between the faces is a dropout or two parts.
MIN_OPENING_M = 0.0015
MAX_OPENING_M = 0.020
# A V's depth below its opening: at most 1.37 x its width for an included angle of 40 degrees
# or more (1 / (2 tan 20)).
MAX_DEPTH_PER_OPENING = 1.5
MIN_SIDE_POINTS = 5
# The least noise a face is taken to have (1 mm depth steps: 1 mm / sqrt(12)), as for the V-groove.
SURFACE_NOISE_FLOOR_M = 0.0003
# Points of the V closer than this across the section belong to one V.
NOTCH_GAP_M = 0.003
# The gaps between a face's points next to its edge that give its point spacing there.
EDGE_GAPS = 5
# A wall's line meets its face at most this far beyond the face's last point; farther, the line
# is noise.
WALL_REACH_M = 0.003
# The spacing of the hinge positions tried for a wall's edge (m).
HINGE_STEP_M = 0.00005
# A V wall turns at least this far from its face (they meet at 65 degrees or more: faces 30-70 degrees
# from the bisector, walls 20-45 on its other side); a gentler bend is the face's own noise.
MIN_WALL_TURN_DEG = 45.0
# The hinge reads the points from the face out to this share of the way from the face's end to the V's
# bottom: deeper lie the root gap's walls and what is seen through it, not the wall.
WALL_SHARE = 0.8
# The fewest points past a hinge that show a wall: its position and slope, and one to spare.
MIN_WALL_POINTS = 3
# The V is cut symmetrically about the faces' bisector: its two edges lie equally far from it, within
# the edges' noise (2 sigma) or this (per section, 96-100 % of the sections of the outside corners
# of seeds 0-29 lie within it; a plate's edge lying on a wedge, 4-28 %).
MAX_ASYMMETRY_M = 0.0015
# A face ends at its last point within max(EDGE_SIGMAS sigma, MIN_EDGE_BAND_M) of its line.
EDGE_SIGMAS = 2.5
MIN_EDGE_BAND_M = 0.0003


def fit(profile: SortedProfile) -> ProfileFit | NoFit:
    """The outside corner in a profile, or why there is none."""
    u, w, params = profile.u, profile.w, profile.params
    split = _best_break(u, w)
    if split is None:
        return NoFit("too few points for two faces")
    # Points seen through the root gap, far below the roof, pull the least-squares break off the
    # ridge by millimetres: the faces are split again where their robust lines meet.
    first = _faces(u, w, split, min_fraction=0.0)
    faces = None if first is None else _faces(u, w, _apex_split(u, first, split), MIN_INLIER_FRACTION)
    if faces is None:
        return NoFit("a face is not a straight line")
    (a_left, b_left, sigma_left, _), (a_right, b_right, sigma_right, _) = faces
    if not (b_left > 0 > b_right):  # convex: both faces fall away from the ridge
        return NoFit("the two faces do not form a convex ridge")
    # Checked last: most profiles are no ridge, and the bow of each face costs a parabola fit.
    if any(_curved(*on) for *_, on in (*first, *faces)):
        return NoFit("a face is not a straight line")
    to_left, to_right = unit(np.array([-1.0, -b_left])), unit(np.array([1.0, b_right]))
    roof = np.degrees(np.arccos(np.clip(to_left @ to_right, -1.0, 1.0)))
    if not (MIN_ROOF_DEG <= roof <= MAX_ROOF_DEG):
        return NoFit("the faces' included angle is outside 60-140 degrees")
    sigma = max(sigma_left, sigma_right, SURFACE_NOISE_FLOOR_M)
    depth = np.minimum(a_left + b_left * u, a_right + b_right * u) - w  # below the roof
    shallow = depth <= max(3 * sigma, 0.4 * params.groove_min_depth_m)
    apex_u = (a_right - a_left) / (b_left - b_right)
    notch = _notch(u, ~shallow, apex_u)
    # The faces end where the V begins (a hidden V: where their points end toward the ridge).
    left_stop, right_stop = (apex_u, apex_u) if notch is None else (u[notch[0]], u[notch[-1]])
    left_reach = _face_end(u[shallow & (u < left_stop)], -1)[0]
    right_reach = _face_end(u[shallow & (u > right_stop)], 1)[0]
    # Where a face ends: its last point within its own noise of its line (a wall's shallowest points,
    # within the notch threshold, would put the end inside the edge).
    on_left = np.abs(w - (a_left + b_left * u)) <= max(EDGE_SIGMAS * sigma_left, MIN_EDGE_BAND_M)
    on_right = np.abs(w - (a_right + b_right * u)) <= max(EDGE_SIGMAS * sigma_right, MIN_EDGE_BAND_M)
    _, left_edge, left_seen = _face_end(u[on_left & shallow & (u < left_stop)], -1)
    _, right_edge, right_seen = _face_end(u[on_right & shallow & (u > right_stop)], 1)
    if min(left_reach, right_reach) < MIN_FACE_M:
        return NoFit("a face is shorter than 6 mm beside the V")
    if right_edge - left_edge < MIN_OPENING_M:
        return NoFit("the faces run into each other: a plain ridge, no V")
    if right_edge - left_edge > MAX_OPENING_M:
        return NoFit("the faces end too far apart for a V (a dropout)")
    if notch is not None:  # what lies deeper than a V that wide is seen through its root gap
        apex_above = a_left + b_left * apex_u - (a_left + b_left * left_edge + a_right + b_right * right_edge) / 2
        in_v = depth <= apex_above + MAX_DEPTH_PER_OPENING * (right_edge - left_edge) + 0.001
        notch = notch[in_v[notch]]
    if notch is None or len(notch) == 0:
        deepest, bottom = None, None
        left_edge, right_edge = left_seen, right_seen
    else:
        deepest = upper_decile(depth[notch])
        if deepest < params.groove_min_depth_m:
            return NoFit("no V below the ridge (shallower than joints.groove_min_depth_m)")
        deep = notch[depth[notch] >= 0.8 * deepest]
        bottom = np.array([median(u[deep]), median(w[deep])])
        v_u, v_w = u[in_v], w[in_v]
        left_edge = _wall_edge(v_u, v_w, (a_left, b_left), left_edge, bottom[0], left_seen)
        right_edge = _wall_edge(v_u, v_w, (a_right, b_right), right_edge, bottom[0], right_seen)
        # A face is what lies outside its edge: a grazing wall's points within its band tilt its line.
        (a_left, b_left), (a_right, b_right) = (
            _outside(u, w, (a_left, b_left), left_edge, -1, sigma_left),
            _outside(u, w, (a_right, b_right), right_edge, 1, sigma_right),
        )
        left_edge = _wall_edge(v_u, v_w, (a_left, b_left), left_edge, bottom[0], left_edge)
        right_edge = _wall_edge(v_u, v_w, (a_right, b_right), right_edge, bottom[0], right_edge)
    geometry = JointGeometry(opening_m=0.0, depth_m=deepest, included_deg=float(roof), legs_m=(left_reach, right_reach))
    return _on_bisector(((a_left, b_left), (a_right, b_right)), (left_edge, right_edge), bottom, geometry, sigma)


def _outside(u, w, face, edge: float, away: int, sigma: float) -> tuple[float, float]:
    """The face's line (intercept, slope) fitted again to its points outside `edge` (toward `away`)
    within max(3 sigma, SURFACE_BAND_M) of it; the line as it was with fewer than MIN_SIDE_POINTS."""
    intercept, slope = face
    on = (away * (u - edge) >= 0) & (np.abs(w - (intercept + slope * u)) <= max(3 * sigma, SURFACE_BAND_M))
    return line(u[on], w[on]) if np.count_nonzero(on) >= MIN_SIDE_POINTS else face


def _on_bisector(faces, edges, bottom, geometry: JointGeometry, sigma: float) -> ProfileFit | NoFit:
    """The fit of faces ((a, b) of w = a + b u, left and right) whose V's top edges lie at u =
    `edges` (left, right), with the V's bottom (u, w) or None: the torch axis is minus the
    bisector of the faces' outward normals. The V is cut symmetrically about it: the seam lies on
    it (the long faces place it well), as deep below the apex as the two edges on average; edges
    lying unequally far from it (by more than max(MAX_ASYMMETRY_M, 2 sigma)) are no such V (a
    plate's edge lying on its support, the step of its end face beside the support's face)."""
    (a_left, b_left), (a_right, b_right) = faces
    left = np.array([edges[0], a_left + b_left * edges[0]])
    right = np.array([edges[1], a_right + b_right * edges[1]])
    normal_left, normal_right = np.array([-b_left, 1.0]), np.array([-b_right, 1.0])  # outward
    axis = -unit(unit(normal_left) + unit(normal_right))
    apex_u = (a_right - a_left) / (b_left - b_right)
    apex = np.array([apex_u, a_left + b_left * apex_u])
    across = np.array([axis[1], -axis[0]])
    if abs(abs((left - apex) @ across) - abs((right - apex) @ across)) > max(MAX_ASYMMETRY_M, 2 * sigma):
        return NoFit("the V's edges lie unequally far from the faces' bisector (no V cut symmetrically)")
    seam = apex + axis * float(((left - apex) @ axis + (right - apex) @ axis) / 2)
    to_left, to_right = unit(np.array([-1.0, -b_left])), unit(np.array([1.0, b_right]))
    outline = (left + to_left, left, seam if bottom is None else bottom, right, right + to_right)
    return ProfileFit(KIND, float(seam[0]), float(seam[1]), float(axis[0]), float(axis[1]), float(sigma),
                      replace(geometry, opening_m=float(np.linalg.norm(right - left))),
                      tuple((float(a), float(b)) for a, b in outline))  # fmt: skip


def _notch(u: np.ndarray, deep: np.ndarray, apex_u: float) -> np.ndarray | None:
    """Indices of the V's points: the run of `deep` points (gaps under NOTCH_GAP_M) nearest the
    apex, within MAX_OPENING_M / 2 of it; None when none lies there."""
    index = np.flatnonzero(deep & (np.abs(u - apex_u) <= MAX_OPENING_M / 2))
    if len(index) == 0:
        return None
    runs = np.split(index, np.flatnonzero(np.diff(u[index]) > NOTCH_GAP_M) + 1)
    return min(runs, key=lambda run: np.abs(u[run] - apex_u).min())


def _wall_edge(u, w, face, face_end: float, bottom_u: float, hidden: float) -> float:
    """Where a V wall turns off its face (`face` = (intercept, slope): the line w = intercept +
    slope u), from the depths below the face r = w - face(u) of the points from WALL_REACH_M
    beyond the face's end to WALL_SHARE of the way to the V's bottom: the hinge e, on a
    HINGE_STEP_M grid from there to the wall's middle, that best explains them as 0 up to e and
    m d past it (d the distance past e toward the bottom, m < 0 by least squares; the wall must
    turn at least MIN_WALL_TURN_DEG off the face): e maximising (sum r d)^2 / sum d^2.

    Every point beside the edge counts: a grazing wall's points, smeared along the line of sight,
    lie within the face's noise band for a millimetre past its edge, so the face's last point in
    the band lies up to that far inside it (and the seam, on the bisector, that much too high).
    Where no wall is seen so (fewer than MIN_WALL_POINTS past e, or none below the face), `hidden`:
    just past the face's last point, where a hidden wall's edge lies."""
    intercept, slope = face
    side = np.sign(face_end - bottom_u)  # the face lies this way from the bottom
    outer, inner = face_end + side * WALL_REACH_M, (face_end + bottom_u) / 2
    window = (u - (face_end + WALL_SHARE * (bottom_u - face_end))) * side >= 0
    window &= (outer - u) * side >= 0
    if np.count_nonzero(window) < MIN_WALL_POINTS or abs(outer - inner) < HINGE_STEP_M:
        return hidden
    uw, depth = u[window], w[window] - (intercept + slope * u[window])
    edges = np.arange(outer, inner, -side * HINGE_STEP_M)
    past = np.maximum(side * (edges[:, None] - uw[None, :]), 0.0)
    product, spread = past @ depth, np.einsum("ij,ij->i", past, past)
    drop = product / np.maximum(spread, 1e-18)  # the wall's depth below the face per unit u past e
    turn = np.abs(np.arctan(slope - side * drop) - np.arctan(slope))
    steep = (product < 0) & (spread > 0) & (turn >= np.radians(MIN_WALL_TURN_DEG))
    score = np.where(steep, product * drop, 0.0)
    best = int(np.argmax(score))
    if score[best] <= 0 or np.count_nonzero(past[best] > 0) < MIN_WALL_POINTS:
        return hidden
    return float(edges[best])


def _faces(u: np.ndarray, w: np.ndarray, split: int, min_fraction: float) -> list | None:
    """The lines (_face) of the faces left and right of the break before index `split`, or None
    where one is not straight (fewer than `min_fraction` of its side's points on its line)."""
    faces = [_face(u[:split], w[:split], -1, min_fraction), _face(u[split:], w[split:], 1, min_fraction)]
    return None if any(face is None for face in faces) else faces


def _apex_split(u: np.ndarray, faces: list, split: int) -> int:
    """The index of the first point right of where the faces' lines meet (the ridge), or `split`
    where they meet in no place that leaves each side its points (parallel lines, or near a
    window's edge)."""
    (a_left, b_left, *_), (a_right, b_right, *_) = faces
    if b_left == b_right:
        return split
    index = int(np.searchsorted(u, (a_right - a_left) / (b_left - b_right)))
    return index if 2 * MIN_SIDE_POINTS <= index <= len(u) - 2 * MIN_SIDE_POINTS else split


def _face(u: np.ndarray, w: np.ndarray, away: int, min_fraction: float) -> tuple | None:
    """(intercept, slope, noise, (u, w) of the points on it) of one face's line, or None where too
    few points lie on it (fewer than `min_fraction`; whether they bow off it is for the caller to
    ask: _curved): started through the half of its points farthest from the
    break (toward `away`; the V beside the ridge does not tilt it), then twice the points within
    max(3 sigma, SURFACE_BAND_M) of the line and the line through them, sigma the noise of the
    points the line was fitted to (the V's and the other face's points beside it are not noise)."""
    if len(u) < 2 * MIN_SIDE_POINTS:
        return None
    inliers = away * (u - median(u)) >= 0
    for _ in range(2):
        intercept, slope = line(u[inliers], w[inliers])
        residual = w - (intercept + slope * u)
        inliers = np.abs(residual) <= max(3 * noise(residual[inliers]), SURFACE_BAND_M)
        if np.count_nonzero(inliers) < MIN_SIDE_POINTS:
            return None
    if fraction(inliers) < min_fraction:
        return None
    on = u[inliers], w[inliers]
    intercept, slope = line(*on)
    return intercept, slope, noise(on[1] - (intercept + slope * on[0])), on


def _curved(u: np.ndarray, w: np.ndarray) -> bool:
    """Whether a face's points bow off a line: the sagitta |c| (L/2)^2 of the parabola w = a + b u
    + c u^2 through them over their extent L exceeds max(3 sigma, MAX_SAGITTA_M), sigma the noise
    about the parabola. The band around a face's line follows its own residuals, and a pipe's arc
    seen across (a 20 mm chord of a 28 mm radius bows 1.8 mm) then passes for two plates' faces."""
    half = np.ptp(u) / 2
    if len(u) < 4 or half <= 0:
        return False
    centred = u - u.mean()
    coefficients = parabola(centred, w)
    sagitta = abs(coefficients[2]) * half * half
    return sagitta > max(3 * noise(w - parabola_at(coefficients, centred)), MAX_SAGITTA_M)


def _face_end(u: np.ndarray, away: int) -> tuple[float, float, float]:
    """(reach, end, edge) of a face's points at positions u, running away from the ridge toward
    `away`: its point nearest the ridge, how far from it the points run on with gaps of at most
    MAX_FACE_SPACING_M (0, nan with no points), and where the face's edge lies when the V's wall
    beyond it is hidden: half a point spacing (the median of the EDGE_GAPS gaps there) past its
    last point, the expected distance from an edge to the last sample before it."""
    if len(u) == 0:
        return 0.0, float("nan"), float("nan")
    ordered = np.sort(u)[::away]  # nearest the ridge first
    steps = np.abs(np.diff(ordered))
    gaps = np.flatnonzero(steps > MAX_FACE_SPACING_M)
    last = ordered[gaps[0]] if len(gaps) else ordered[-1]
    spacing = middle(steps[:EDGE_GAPS]) if len(steps) else 0.0
    return float(abs(last - ordered[0])), float(ordered[0]), float(ordered[0] - away * spacing / 2)


def _best_break(u: np.ndarray, w: np.ndarray) -> int | None:
    """The break (index of the first point right of it) minimising the residual sum of squares of
    a line each side, from running sums, or None."""
    n = len(u)
    splits = np.arange(2 * MIN_SIDE_POINTS, n - 2 * MIN_SIDE_POINTS + 1)
    if len(splits) == 0:
        return None
    sums = np.cumsum(np.column_stack([np.ones(n), u, w, u * u, u * w, w * w]), axis=0)
    left = sums[splits - 1]
    error = line_sse(left) + line_sse(sums[-1] - left)
    return int(splits[int(np.argmin(error))])
