"""Synthetic workpieces with known weld seams: triangle meshes on a table plus ground truth.

Solids are built exactly, never by booleans: plates are convex polytopes cut by bevel planes,
curved grooves are a grooved cross-section swept along a curve sampled every 0.5 mm (the
truth uses the same samples). A rendered point therefore lies on the true surface to float32
precision. Units: metres and radians; base frame z up, table top at z = 0.

Ground truth. V-groove: the seam point is the centre of the groove opening at the plate
surface (midpoint of the two top edges, in the air above the groove) and the torch axis is
the negated surface normal. Fillet (inside corner): the seam point is on the corner line and
the torch axis bisects the two faces' inward directions. The further joints (lap, bevel,
square butt, outside corner, pipe on plate, saddle, tacks, clutter, curved valley) are in
joints.py, pipes.py and valley.py; catalog.py lists every family and draws a case.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np
import trimesh

from weldseam.geometry import transform_points, unit
from weldseam.synthetic.sensor import (
    D415, SensorNoise, cast_rays, look_at, render_depth, scan_points,
)
from weldseam.types import Intrinsics

SEAM_SPACING_M = 0.0005
TABLE_EXTENTS_M = (0.8, 0.8, 0.03)
UP = np.array([0.0, 0.0, 1.0])


class Tack(NamedTuple):
    """A tack weld on a seam: its centre on the seam line (3,) m, its length along the seam
    and its height above the surface (m)."""

    centre_m: np.ndarray
    length_m: float
    height_m: float


@dataclass(frozen=True, eq=False)
class TruthSeam:
    """Ground-truth seam.

    points_m: (M, 3) base-frame points every ~0.5 mm along the seam, in travel order.
    torch_axes: (M, 3) unit torch axes pointing INTO the work.
    closed: the seam is a loop (the last point joins the first).
    joint: the kind, as the planner names it: "v_groove", "bevel", "square_butt",
        "fillet" (inside corners, ring fillets and saddles included), "lap",
        "outside_corner".
    tacks: the tack welds on this seam (part of the seam: the path runs across them).
    Holds arrays, so equality is identity.
    """

    points_m: np.ndarray
    torch_axes: np.ndarray
    closed: bool
    joint: str
    tacks: tuple[Tack, ...] = ()


@dataclass(frozen=True, eq=False)
class SyntheticScene:
    """A workpiece on the table, its truth seams and where a camera should look.

    mesh: the whole scene (table, parts and fixtures), base frame.
    camera_target_m: (3,) point for the camera to look at.
    view_axis_m: (3,) unit direction from the target toward a good camera position;
        `default_camera` tilts it by up to `max_view_tilt_deg` (degrees).
    parts: the workpiece's solids; fixtures: supports, clamps and loose bars (never a
        seam), each a closed mesh in the base frame.
    occluder: the mesh that can hide a truth point (None: `mesh`). Tacked seams leave
        their tacks out: a tack is part of its seam, so the seam under it counts as seen.
    """

    name: str
    mesh: trimesh.Trimesh
    seams: tuple[TruthSeam, ...]
    camera_target_m: np.ndarray
    view_axis_m: np.ndarray = field(default_factory=lambda: UP.copy())
    max_view_tilt_deg: float = 30.0
    parts: tuple[trimesh.Trimesh, ...] = ()
    fixtures: tuple[trimesh.Trimesh, ...] = ()
    occluder: trimesh.Trimesh | None = None


@dataclass(frozen=True, eq=False)
class SyntheticScan:
    """One rendered frame of a scene.

    depth: (H, W) uint16 depth image; points_m: (N, 3) its valid pixels in the base frame.
    T_base_camera: (4, 4); camera_origin_m: (3,) camera centre in the base frame.
    visible: one (M_k,) bool mask per truth seam: which truth points the camera observed.
    """

    depth: np.ndarray
    intrinsics: Intrinsics
    T_base_camera: np.ndarray
    points_m: np.ndarray
    camera_origin_m: np.ndarray
    visible: tuple[np.ndarray, ...]


class _VGroove(NamedTuple):
    """A V-groove's cross-section: half the included angle (rad) and the root gap (m; in
    swept grooves the width of the flat bottom)."""

    half_angle_rad: float
    root_gap_m: float


# ---------------------------------------------------------------- mesh building blocks


def _draw(rng: np.random.Generator, value, low: float, high: float) -> float:
    """`value` when given, else a uniform draw from [low, high)."""
    return float(rng.uniform(low, high)) if value is None else float(value)


def _draw_groove(rng, included_angle_deg, root_gap_m, max_gap_m: float) -> _VGroove:
    """A _VGroove from the given values or random defaults (angle 60-90 deg, gap up to
    `max_gap_m`)."""
    return _VGroove(
        np.radians(_draw(rng, included_angle_deg, 60.0, 90.0)) / 2,
        _draw(rng, root_gap_m, 0.0, max_gap_m),
    )


def _box(lower, upper) -> trimesh.Trimesh:
    """Axis-aligned box between corners `lower` and `upper` (3,)."""
    return trimesh.creation.box(bounds=np.array([lower, upper], dtype=np.float64))


def _convex_solid(normals: np.ndarray, offsets: np.ndarray) -> trimesh.Trimesh:
    """The convex polytope {p : normals @ p <= offsets}; normals (K, 3), offsets (K,)."""
    from scipy.optimize import linprog
    from scipy.spatial import HalfspaceIntersection

    normals, offsets = np.asarray(normals, float), np.asarray(offsets, float)
    # Chebyshev centre: the strictly interior point HalfspaceIntersection needs.
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    centre = linprog(
        c=[0.0, 0.0, 0.0, -1.0], A_ub=np.hstack([normals, lengths]), b_ub=offsets,
        bounds=[(None, None)] * 3 + [(0.0, None)],
    )
    if not centre.success or centre.x[3] <= 1e-6:
        raise ValueError("convex piece is empty or thinner than a micrometre")
    corners = HalfspaceIntersection(np.hstack([normals, -offsets[:, None]]), centre.x[:3])
    return trimesh.convex.convex_hull(corners.intersections)


def _plate_piece(thickness_m, bounds, bevels, groove: _VGroove, root_face_m) -> trimesh.Trimesh:
    """Convex plate piece, 0 <= z <= thickness_m, bevelled along straight V-grooves.

    bounds: ((nx, ny), c) pairs, the piece keeps nx x + ny y <= c.
    bevels: ((qx, qy), (nx, ny)) pairs, a groove centre line through q with unit normal n
        pointing into the piece; the piece keeps n.(p - q) >= root_gap / 2 (the root face,
        up to height root_face_m) and its bevel face leans back by the half angle above it.
    """
    tan_half = np.tan(groove.half_angle_rad)
    normals = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]
    offsets = [thickness_m, 0.0]
    for (nx, ny), c in bounds:
        normals.append((nx, ny, 0.0))
        offsets.append(c)
    for q, (nx, ny) in bevels:
        limit = -(nx * q[0] + ny * q[1]) - groove.root_gap_m / 2
        normals += [(-nx, -ny, 0.0), (-nx, -ny, tan_half)]
        offsets += [limit, limit + root_face_m * tan_half]
    return _convex_solid(np.array(normals), np.array(offsets))


def _rectangle(half_x_m: float, half_y_m: float) -> list:
    """Bounds (for _plate_piece) of the rectangle |x| <= half_x_m, |y| <= half_y_m."""
    return [((1.0, 0.0), half_x_m), ((-1.0, 0.0), half_x_m),
            ((0.0, 1.0), half_y_m), ((0.0, -1.0), half_y_m)]


def _quads(a, b, c, d) -> np.ndarray:
    """Triangles (2n, 3) of quads with corner indices a, b, c, d (n,) in order."""
    a, b, c, d = (np.ravel(x) for x in (a, b, c, d))
    return np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def _swept_solid(origins, across, up, offsets_m, heights_m, base_m, closed) -> trimesh.Trimesh:
    """Solid swept by a cross-section along a sampled curve.

    The section is {(t, h): offsets_m[0] <= t <= offsets_m[-1], base_m <= h <= height(t)},
    height piecewise linear through (offsets_m, heights_m) (J,). Section i puts (t, h) at
    origins[i] + t across[i] + h up[i]; origins, across, up are (I, 3). base_m is a number
    or (I, J), a base height per section and offset (a bottom that follows a curved
    surface). closed: the last section joins the first (a ring); otherwise both ends are
    capped.
    """
    offsets = np.asarray(offsets_m, float)[None, :, None]
    heights = np.asarray(heights_m, float)[None, :, None]
    origins, across, up = (np.asarray(a, float)[:, None, :] for a in (origins, across, up))
    top = origins + offsets * across + heights * up
    base = np.asarray(base_m, float)
    bottom = origins + offsets * across + (base[..., None] if base.ndim else base) * up
    count, width = top.shape[:2]
    index = np.arange(2 * count * width).reshape(2, count, width)
    this = np.arange(count if closed else count - 1)
    after = (this + 1) % count
    top_i, bottom_i = index
    faces = [
        _quads(top_i[this, :-1], top_i[this, 1:], top_i[after, 1:], top_i[after, :-1]),
        _quads(bottom_i[this, :-1], bottom_i[after, :-1], bottom_i[after, 1:], bottom_i[this, 1:]),
        _quads(top_i[this, 0], top_i[after, 0], bottom_i[after, 0], bottom_i[this, 0]),
        _quads(top_i[this, -1], bottom_i[this, -1], bottom_i[after, -1], top_i[after, -1]),
    ]
    if not closed:
        faces += [
            _quads(top_i[0, :-1], bottom_i[0, :-1], bottom_i[0, 1:], top_i[0, 1:]),
            _quads(top_i[-1, :-1], top_i[-1, 1:], bottom_i[-1, 1:], bottom_i[-1, :-1]),
        ]
    mesh = trimesh.Trimesh(
        np.concatenate([top.reshape(-1, 3), bottom.reshape(-1, 3)]), np.concatenate(faces),
        process=False,
    )
    if mesh.volume < 0:  # the winding above depends on the handedness of (curve, across, up)
        mesh.invert()
    return mesh


def _groove_section(half_width_m, thickness_m, groove_depth_m, groove: _VGroove, centre_m=0.0):
    """(offsets, heights) of a plate top with one V-groove (flat bottom = root gap) at
    `centre_m`, over [centre_m - half_width_m, centre_m + half_width_m]."""
    half_open = groove.root_gap_m / 2 + groove_depth_m * np.tan(groove.half_angle_rad)
    half_gap = groove.root_gap_m / 2
    offsets = np.array([-half_width_m, -half_open, -half_gap, half_gap, half_open, half_width_m])
    heights = np.array([0, 0, -groove_depth_m, -groove_depth_m, 0, 0]) + thickness_m
    keep = np.r_[True, np.diff(offsets) > 0]
    return offsets[keep] + centre_m, heights[keep]


def _line(start, end) -> np.ndarray:
    """(M, 3) points from `start` to `end` (3,) at most SEAM_SPACING_M apart."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    count = max(2, int(np.ceil(np.linalg.norm(end - start) / SEAM_SPACING_M)) + 1)
    return start + np.linspace(0.0, 1.0, count)[:, None] * (end - start)


def _seam(points, axes, joint: str, closed: bool = False) -> TruthSeam:
    """TruthSeam with `axes` (3,) or (M, 3) broadcast to the points and normalised."""
    points = np.asarray(points, float)
    return TruthSeam(points, unit(np.broadcast_to(axes, points.shape).astype(float)), closed, joint)


def _moved(matrix: np.ndarray, meshes, seams):
    """Copies of `meshes` and `seams` moved by the rigid (4, 4) `matrix`."""
    meshes = [mesh.copy().apply_transform(matrix) for mesh in meshes]
    seams = [
        TruthSeam(transform_points(matrix, s.points_m), s.torch_axes @ matrix[:3, :3].T,
                  s.closed, s.joint,
                  tuple(t._replace(centre_m=transform_points(matrix, t.centre_m[None])[0])
                        for t in s.tacks))
        for s in seams
    ]
    return meshes, seams


def _rotation(axis, angle_rad: float) -> np.ndarray:
    """(4, 4) rotation about `axis` (3,) through the origin."""
    return trimesh.transformations.rotation_matrix(angle_rad, np.asarray(axis, float))


def _table() -> trimesh.Trimesh:
    """The table: a slab whose top is z = 0."""
    return _box(
        [-TABLE_EXTENTS_M[0] / 2, -TABLE_EXTENTS_M[1] / 2, -TABLE_EXTENTS_M[2]],
        [TABLE_EXTENTS_M[0] / 2, TABLE_EXTENTS_M[1] / 2, 0.0],
    )


def _scene(name, parts, seams, target, yaw_rad, view_axis=UP, max_view_tilt_deg=30.0,
           fixtures=(), hidden=()):
    """SyntheticScene: workpiece `parts`, `fixtures` and truth turned by `yaw_rad` about the
    base z axis, set on the table. `hidden`: indices of parts that hide no truth (tacks)."""
    turn = _rotation(UP, yaw_rad)
    parts, seams = _moved(turn, parts, seams)
    fixtures, _ = _moved(turn, fixtures, [])
    table = _table()
    occluder = None
    if hidden:
        occluder = trimesh.util.concatenate(
            [table, *(p for k, p in enumerate(parts) if k not in hidden), *fixtures]
        )
    return SyntheticScene(
        name=name,
        mesh=trimesh.util.concatenate([table, *parts, *fixtures]),
        seams=tuple(seams),
        camera_target_m=transform_points(turn, np.asarray(target, float)[None])[0],
        view_axis_m=unit(turn[:3, :3] @ np.asarray(view_axis, float)),
        max_view_tilt_deg=max_view_tilt_deg,
        parts=tuple(parts),
        fixtures=tuple(fixtures),
        occluder=occluder,
    )


def _yaw(rng, yaw_deg) -> float:
    """Yaw in radians: `yaw_deg` when given, else uniform over the full turn."""
    return np.radians(_draw(rng, yaw_deg, 0.0, 360.0))


# ---------------------------------------------------------------- families


def _butt_plates(thickness_m, groove: _VGroove, root_face_m, length_m, plate_width_m):
    """Two plates bevelled for a single-V butt joint along y at x = 0 (the root gap goes
    through the plate); returns (meshes, truth seam)."""
    half_span = groove.root_gap_m / 2 + plate_width_m
    plates = [
        _plate_piece(
            thickness_m,
            [((side, 0.0), half_span), ((0.0, 1.0), length_m / 2), ((0.0, -1.0), length_m / 2)],
            [((0.0, 0.0), (side, 0.0))],
            groove,
            root_face_m,
        )
        for side in (-1.0, 1.0)
    ]
    points = _line([0, -length_m / 2, thickness_m], [0, length_m / 2, thickness_m])
    return plates, _seam(points, -UP, "v_groove")


def v_butt(
    rng: np.random.Generator, *, thickness_m=None, included_angle_deg=None, root_gap_m=None,
    root_face_m=None, length_m=None, plate_width_m=None, yaw_deg=None,
) -> SyntheticScene:
    """Two bevelled plates side by side, a straight single-V groove between them.

    Defaults: thickness 6-12 mm, included angle 60-90 deg, root gap 0-2 mm, root face
    0.5-2 mm, length 180-220 mm, each plate 60-90 mm wide, random yaw.
    """
    thickness = _draw(rng, thickness_m, 0.006, 0.012)
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    root_face = _draw(rng, root_face_m, 0.0005, 0.002)
    plates, seam = _butt_plates(
        thickness, groove, root_face, _draw(rng, length_m, 0.18, 0.22),
        _draw(rng, plate_width_m, 0.06, 0.09),
    )
    return _scene("v_butt", plates, [seam], [0, 0, thickness], _yaw(rng, yaw_deg))


def inclined_plates(
    rng: np.random.Generator, *, incline_deg=None, incline_axis_deg=None, support_height_m=None,
    thickness_m=None, included_angle_deg=None, root_gap_m=None, root_face_m=None, length_m=None,
    plate_width_m=None, yaw_deg=None,
) -> SyntheticScene:
    """A v_butt pair tilted by `incline_deg` (15-35) about a horizontal axis at
    `incline_axis_deg` (0-180) from the seam, resting on a wedge support whose lowest
    edge is `support_height_m` (10-30 mm) high. Other parameters as in `v_butt`."""
    thickness = _draw(rng, thickness_m, 0.006, 0.012)
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    root_face = _draw(rng, root_face_m, 0.0005, 0.002)
    length, width = _draw(rng, length_m, 0.18, 0.22), _draw(rng, plate_width_m, 0.06, 0.09)
    plates, seam = _butt_plates(thickness, groove, root_face, length, width)
    axis_angle = np.radians(_draw(rng, incline_axis_deg, 0.0, 180.0))
    tilt = _rotation(
        [np.sin(axis_angle), np.cos(axis_angle), 0.0], np.radians(_draw(rng, incline_deg, 15, 35))
    )
    half_span = groove.root_gap_m / 2 + width
    corners = transform_points(tilt, np.array(
        [[sx * half_span, sy * length / 2, 0.0] for sx in (-1, 1) for sy in (-1, 1)]
    ))
    lift = np.eye(4)
    lift[2, 3] = _draw(rng, support_height_m, 0.01, 0.03) - corners[:, 2].min()
    plates, (seam,) = _moved(lift @ tilt, plates, [seam])
    corners = transform_points(lift, corners)
    support = trimesh.convex.convex_hull(np.vstack([corners, corners * [1, 1, 0]]))
    target = seam.points_m[len(seam.points_m) // 2]
    return _scene("inclined_plates", plates, [seam], target, _yaw(rng, yaw_deg),
                  fixtures=[support])


def _curve_section_frames(points_xy: np.ndarray):
    """Origins (I, 3) at z = 0 and in-plane left normals (I, 3) along a planar curve (I, 2)."""
    tangents = unit(np.gradient(points_xy, axis=0))
    zeros = np.zeros(len(points_xy))
    return (np.column_stack([points_xy, zeros]),
            np.column_stack([-tangents[:, 1], tangents[:, 0], zeros]))


def _resample(points_xy: np.ndarray, spacing_m: float) -> np.ndarray:
    """A densely sampled planar curve (N, 2) resampled at equal arc-length steps."""
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points_xy, axis=0), axis=1))]
    stations = np.linspace(0.0, arc[-1], int(np.ceil(arc[-1] / spacing_m)) + 1)
    return np.column_stack([np.interp(stations, arc, points_xy[:, k]) for k in (0, 1)])


def curved_groove(
    rng: np.random.Generator, *, shape=None, thickness_m=None, groove_depth_m=None,
    included_angle_deg=None, root_gap_m=None, length_m=None, radius_m=None, amplitude_m=None,
    yaw_deg=None,
) -> SyntheticScene:
    """A V-groove along a planar curve, milled into a thick plate that follows the curve
    (a band 70-80 mm wide).

    shape: "arc" (radius 80-150 mm, arc length `length_m` 150-200 mm) or "s_curve"
    (y = A sin(2 pi x / L), A 8-15 mm, L 180-220 mm); random when None. Thickness 8-14 mm,
    groove depth 40-70 % of it, included angle 60-90 deg, flat bottom 0-2 mm wide.
    """
    shape = shape if shape is not None else str(rng.choice(["arc", "s_curve"]))
    thickness = _draw(rng, thickness_m, 0.008, 0.014)
    depth = _draw(rng, groove_depth_m, 0.4 * thickness, 0.7 * thickness)
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    if shape == "arc":
        radius = _draw(rng, radius_m, 0.08, 0.15)
        length = _draw(rng, length_m, 0.15, 0.20)
        angles = np.linspace(-0.5, 0.5, int(np.ceil(length / SEAM_SPACING_M)) + 1) * length / radius
        curve = radius * np.column_stack([np.sin(angles), np.cos(angles) - 1.0])
        half_width = 0.04
    elif shape == "s_curve":
        amplitude = _draw(rng, amplitude_m, 0.008, 0.015)
        length = _draw(rng, length_m, 0.18, 0.22)
        x = np.linspace(-length / 2, length / 2, 20001)
        curve = _resample(np.column_stack([x, amplitude * np.sin(2 * np.pi * x / length)]),
                          SEAM_SPACING_M)
        # Offsets must stay inside the tightest radius of curvature, L^2 / (4 pi^2 A).
        half_width = min(0.04, 0.75 * length**2 / (4 * np.pi**2 * amplitude))
    else:
        raise ValueError(f"curved_groove: shape must be 'arc' or 's_curve', got {shape!r}")
    origins, across = _curve_section_frames(curve)
    offsets, heights = _groove_section(half_width, thickness, depth, groove)
    plate = _swept_solid(origins, across, np.broadcast_to(UP, origins.shape), offsets, heights,
                         0.0, closed=False)
    seam = _seam(origins + [0, 0, thickness], -UP, "v_groove")
    return _scene(f"curved_groove({shape})", [plate], [seam], [0, 0, thickness],
                  _yaw(rng, yaw_deg))


def _circle(radius_m: float):
    """(n, 3) unit radial directions in the xy plane for a circle sampled every ~0.5 mm."""
    angles = np.linspace(0, 2 * np.pi, int(np.ceil(2 * np.pi * radius_m / SEAM_SPACING_M)),
                         endpoint=False)
    return np.column_stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])


def ring_groove(
    rng: np.random.Generator, *, radius_m=None, thickness_m=None, groove_depth_m=None,
    included_angle_deg=None, root_gap_m=None, yaw_deg=None,
) -> SyntheticScene:
    """A closed circular V-groove (radius 40-70 mm) in a round flange plate (outer radius
    30-45 mm beyond the groove, centre hole 10-20 mm radius, 10-16 mm thick, groove 4-8 mm
    deep, flat bottom 0-2 mm). One closed seam, seen from above."""
    radius = _draw(rng, radius_m, 0.04, 0.07)
    thickness = _draw(rng, thickness_m, 0.010, 0.016)
    depth = _draw(rng, groove_depth_m, 0.004, min(0.008, thickness - 0.003))
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    hole, outer = rng.uniform(0.010, 0.020), radius + rng.uniform(0.030, 0.045)
    offsets, heights = _groove_section(outer - radius, thickness, depth, groove, centre_m=radius)
    offsets[0] = hole
    radial = _circle(radius)
    plate = _swept_solid(np.zeros_like(radial), radial, np.broadcast_to(UP, radial.shape),
                         offsets, heights, 0.0, closed=True)
    seam = _seam(radius * radial + [0, 0, thickness], -UP, "v_groove", closed=True)
    return _scene("ring_groove", [plate], [seam], [0, 0, thickness], _yaw(rng, yaw_deg))


def pipe_groove(
    rng: np.random.Generator, *, outer_radius_m=None, wall_m=None, length_m=None,
    groove_depth_m=None, included_angle_deg=None, root_gap_m=None, side=None, yaw_deg=None,
) -> SyntheticScene:
    """A pipe lying on the table (outer radius 50-80 mm, wall 6-10 mm, 200-300 mm long)
    with a circumferential V-groove in the middle (depth = wall - 1..2 mm, flat bottom
    0-2 mm): two pipe sections butted. The truth is the whole closed circle; the camera
    looks from side-above (`side` +-1 across the axis), so the visible part is an arc."""
    radius = _draw(rng, outer_radius_m, 0.05, 0.08)
    wall = _draw(rng, wall_m, 0.006, 0.010)
    length = _draw(rng, length_m, 0.20, 0.30)
    depth = _draw(rng, groove_depth_m, wall - 0.002, wall - 0.001)
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    side = side if side is not None else float(rng.choice([-1.0, 1.0]))
    offsets, heights = _groove_section(length / 2, radius, depth, groove)
    radial = _circle(radius)[:, [2, 0, 1]]  # circles in the y-z plane, the pipe axis is x
    centre = np.array([0.0, 0.0, radius])
    pipe = _swept_solid(np.broadcast_to(centre, radial.shape),
                        np.broadcast_to([1.0, 0.0, 0.0], radial.shape), radial,
                        offsets, heights, radius - wall, closed=True)
    seam = _seam(centre + radius * radial, -radial, "v_groove", closed=True)
    view = np.array([0.0, side * np.sin(np.radians(30)), np.cos(np.radians(30))])
    return _scene("pipe_groove", [pipe], [seam], centre + radius * view, _yaw(rng, yaw_deg),
                  view_axis=view, max_view_tilt_deg=10.0)


def block_groove(
    rng: np.random.Generator, *, width_m=None, depth_m=None, height_m=None, groove_depth_m=None,
    included_angle_deg=None, root_gap_m=None, side=None, yaw_deg=None,
) -> SyntheticScene:
    """A block (80-120 mm along x, 80-120 mm along y, 90-110 mm tall) with a V-groove
    (4-8 mm deep, flat bottom 0-2 mm) in the plane y = 0: up the -x face, over the top,
    down the +x face (an inverted U with 90-degree bends). The camera looks from above the
    `side` (+-1) face, so the top run and that face's run are visible."""
    width = _draw(rng, width_m, 0.08, 0.12)
    across = _draw(rng, depth_m, 0.08, 0.12)
    height = _draw(rng, height_m, 0.09, 0.11)
    depth = _draw(rng, groove_depth_m, 0.004, 0.008)
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    side = side if side is not None else float(rng.choice([-1.0, 1.0]))
    # Cross-sections at constant y are rectangles shrunk by the groove depth delta(y) on the
    # -x, top and +x faces; between breakpoints delta is linear, so each slab is convex.
    half_gap = groove.root_gap_m / 2
    half_open = half_gap + depth * np.tan(groove.half_angle_rad)
    stations = np.unique([-across / 2, -half_open, -half_gap, half_gap, half_open, across / 2])
    delta = np.clip(depth - (np.abs(stations) - half_gap) / np.tan(groove.half_angle_rad), 0, depth)

    def section(y, d):
        return [[x, y, z] for x in (-width / 2 + d, width / 2 - d) for z in (0.0, height - d)]

    slabs = [
        trimesh.convex.convex_hull(np.array(section(y0, d0) + section(y1, d1)))
        for y0, y1, d0, d1 in zip(stations[:-1], stations[1:], delta[:-1], delta[1:])
    ]
    up_left = _line([-width / 2, 0, 0], [-width / 2, 0, height])[:-1]
    over = _line([-width / 2, 0, height], [width / 2, 0, height])[:-1]
    down_right = _line([width / 2, 0, height], [width / 2, 0, 0])
    axes = np.vstack([np.broadcast_to([1.0, 0, 0], up_left.shape),
                      np.broadcast_to(-UP, over.shape),
                      np.broadcast_to([-1.0, 0, 0], down_right.shape)])
    seam = _seam(np.vstack([up_left, over, down_right]), axes, "v_groove")
    view = unit(np.array([side * np.sin(np.radians(35)), 0.0, np.cos(np.radians(35))]))
    target = [side * width / 4, 0.0, 0.6 * height]
    return _scene("block_groove", slabs, [seam], target, _yaw(rng, yaw_deg),
                  view_axis=view, max_view_tilt_deg=10.0)


def fillet_t(
    rng: np.random.Generator, *, flange_thickness_m=None, flange_width_m=None,
    web_thickness_m=None, web_height_m=None, length_m=None, side=None, yaw_deg=None,
) -> SyntheticScene:
    """T-joint: a web plate (6-12 mm thick, 40-80 mm high) standing on a flange plate
    (8-12 mm thick, 120-180 mm wide), both 150-250 mm long along x. Both inside corners are
    fillet seams. No single viewpoint sees both corner lines (the web hides the far one), so
    the camera looks from side-above the `side` (+-1 in y) corner."""
    flange_t = _draw(rng, flange_thickness_m, 0.008, 0.012)
    flange_w = _draw(rng, flange_width_m, 0.12, 0.18)
    web_t = _draw(rng, web_thickness_m, 0.006, 0.012)
    web_h = _draw(rng, web_height_m, 0.04, 0.08)
    length = _draw(rng, length_m, 0.15, 0.25)
    side = side if side is not None else float(rng.choice([-1.0, 1.0]))
    flange = _box([-length / 2, -flange_w / 2, 0], [length / 2, flange_w / 2, flange_t])
    web = _box([-length / 2, -web_t / 2, flange_t], [length / 2, web_t / 2, flange_t + web_h])
    seams = [
        _seam(_line([-length / 2, s * web_t / 2, flange_t], [length / 2, s * web_t / 2, flange_t]),
              [0.0, -s, -1.0], "fillet")
        for s in (-1.0, 1.0)
    ]
    view = np.array([0.0, side * np.sin(np.radians(35)), np.cos(np.radians(35))])
    return _scene("fillet_t", [flange, web], seams, [0, side * web_t / 2, flange_t],
                  _yaw(rng, yaw_deg), view_axis=view, max_view_tilt_deg=10.0)


def two_grooves(
    rng: np.random.Generator, *, thickness_m=None, groove_depth_m=None, included_angle_deg=None,
    root_gap_m=None, separation_m=None, angle_between_deg=None, yaw_deg=None,
) -> SyntheticScene:
    """A plate (12-20 mm thick, 200 mm long) made of three butted pieces: two V-grooves
    (depth 5-10 mm, root gap 0 unless given) whose centre lines cross the plate's middle
    90-110 mm apart, the second turned by -15..15 deg, so they stay >= 60 mm apart."""
    thickness = _draw(rng, thickness_m, 0.012, 0.020)
    depth = _draw(rng, groove_depth_m, 0.005, min(0.010, thickness - 0.002))
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.0)
    separation = _draw(rng, separation_m, 0.09, 0.11)
    turn = np.radians(_draw(rng, angle_between_deg, -15.0, 15.0))
    half_x, half_y = separation / 2 + 0.06, 0.10
    points = [np.array([-separation / 2, 0.0]), np.array([separation / 2, 0.0])]
    directions = [np.array([0.0, 1.0]), np.array([np.sin(turn), np.cos(turn)])]
    normals = [np.array([d[1], -d[0]]) for d in directions]  # toward +x
    box = _rectangle(half_x, half_y)
    root_face = thickness - depth
    bevels = [
        [(points[0], -normals[0])],
        [(points[0], normals[0]), (points[1], -normals[1])],
        [(points[1], normals[1])],
    ]
    plates = [_plate_piece(thickness, box, b, groove, root_face) for b in bevels]
    seams = [
        _seam(_line([*(p - d * half_y / d[1]), thickness], [*(p + d * half_y / d[1]), thickness]),
              -UP, "v_groove")
        for p, d in zip(points, directions)
    ]
    return _scene("two_grooves", plates, seams, [0, 0, thickness], _yaw(rng, yaw_deg))


def y_groove(
    rng: np.random.Generator, *, thickness_m=None, groove_depth_m=None, included_angle_deg=None,
    root_gap_m=None, branch_angles_deg=None, half_size_m=None,
) -> SyntheticScene:
    """Three butted plate pieces in a square (half size 100-120 mm, 10-16 mm thick) leaving
    three V-grooves (depth 5-10 mm, root gap 0-1 mm) that meet at the centre. Branch angles
    are 120 deg apart +-15 deg (each gap between branches stays below 180 deg). Truth: three
    seams, each from the junction outwards to the plate edge."""
    thickness = _draw(rng, thickness_m, 0.010, 0.016)
    depth = _draw(rng, groove_depth_m, 0.005, min(0.010, thickness - 0.002))
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.001)
    half = _draw(rng, half_size_m, 0.10, 0.12)
    if branch_angles_deg is None:
        branch_angles_deg = rng.uniform(0, 360) + np.array([0, 120, 240]) + rng.uniform(-15, 15, 3)
    angles = np.sort(np.radians(np.asarray(branch_angles_deg, float)) % (2 * np.pi))
    gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
    if len(angles) != 3 or gaps.max() >= np.pi:
        raise ValueError("y_groove: three branches with every gap between them below 180 deg")
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    left = np.column_stack([-directions[:, 1], directions[:, 0]])  # counter-clockwise side
    origin = np.zeros(2)
    plates = [
        _plate_piece(thickness, _rectangle(half, half),
                     [(origin, left[k]), (origin, -left[(k + 1) % 3])], groove,
                     thickness - depth)
        for k in range(3)
    ]
    reach = half / np.abs(directions).max(axis=1)
    seams = [_seam(_line([0, 0, thickness], [*(d * r), thickness]), -UP, "v_groove")
             for d, r in zip(directions, reach)]
    return _scene("y_groove", plates, seams, [0, 0, thickness], 0.0)


def plain_plate(rng: np.random.Generator, *, count=None, yaw_deg=None) -> SyntheticScene:
    """One or two plain plates (100-200 x 80-150 mm, 5-20 mm thick) on the table, 60-100 mm
    apart: no seams."""
    count = int(count if count is not None else rng.integers(1, 3))
    sizes = rng.uniform([0.10, 0.08, 0.005], [0.20, 0.15, 0.020], (count, 3))
    starts = np.r_[0.0, np.cumsum(sizes[:-1, 0] + rng.uniform(0.06, 0.10, count - 1))]
    starts -= (starts[-1] + sizes[-1, 0]) / 2
    plates = [_box([x, -size[1] / 2, 0.0], [x + size[0], size[1] / 2, size[2]])
              for x, size in zip(starts, sizes)]
    return _scene("plain_plate", plates, [], [0, 0, sizes[:, 2].min()], _yaw(rng, yaw_deg))


FAMILIES: dict[str, Callable[..., SyntheticScene]] = {
    "v_butt": v_butt,
    "curved_groove": curved_groove,
    "pipe_groove": pipe_groove,
    "ring_groove": ring_groove,
    "block_groove": block_groove,
    "inclined_plates": inclined_plates,
    "fillet_t": fillet_t,
    "two_grooves": two_grooves,
    "y_groove": y_groove,
    "plain_plate": plain_plate,
}


# ---------------------------------------------------------------- cameras and scans


def default_camera(
    scene: SyntheticScene, rng: np.random.Generator, *, distance_m=None, tilt_deg=None,
) -> np.ndarray:
    """(4, 4) T_base_camera looking at scene.camera_target_m from `distance_m` (0.35-0.6 m)
    along scene.view_axis_m tilted by `tilt_deg` (0 to scene.max_view_tilt_deg) toward a
    random azimuth. Image "up" is base z except for near-vertical views (random roll)."""
    distance = _draw(rng, distance_m, 0.35, 0.6)
    tilt = np.radians(_draw(rng, tilt_deg, 0.0, scene.max_view_tilt_deg))
    axis = unit(np.asarray(scene.view_axis_m, float))
    helper = UP if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    first = unit(np.cross(axis, helper))
    azimuth = rng.uniform(0, 2 * np.pi)
    sideways = np.cos(azimuth) * first + np.sin(azimuth) * np.cross(axis, first)
    direction = np.cos(tilt) * axis + np.sin(tilt) * sideways
    up = UP
    if np.linalg.norm(np.cross(direction, UP)) < np.sin(np.radians(1.0)):
        roll = rng.uniform(0, 2 * np.pi)
        up = np.array([np.cos(roll), np.sin(roll), 0.0])
    target = np.asarray(scene.camera_target_m, float)
    return look_at(target + distance * direction, target, up)


def pixel_of(points_m: np.ndarray, T_base_camera: np.ndarray, intrinsics: Intrinsics):
    """(col, row, depth) each (M,) of base-frame `points_m` (M, 3) in the image of a camera at
    `T_base_camera`: col = fx x / z + cx, row = fy y / z + cy (pixels, not rounded), depth = z (m)
    in the camera frame (col and row inf or nan where z <= 0)."""
    local = transform_points(np.linalg.inv(T_base_camera), points_m)
    depth = local[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return intrinsics.fx * local[:, 0] / depth + intrinsics.cx, intrinsics.fy * local[:, 1] / depth + intrinsics.cy, depth


def visible_mask(
    scene: SyntheticScene, seam: TruthSeam, T_base_camera: np.ndarray,
    intrinsics: Intrinsics = D415, *, occlusion_tolerance_m: float = 0.001,
    max_view_angle_deg: float = 70.0,
) -> np.ndarray:
    """(M,) bool: truth points the camera observes. A point counts when it projects into the
    image, the ray from the camera to it hits nothing (of scene.occluder, else scene.mesh)
    more than `occlusion_tolerance_m` before it (V-groove points are in the air: the ray is
    cast to them), and the ray is within `max_view_angle_deg` of the torch axis."""
    camera = T_base_camera[:3, 3]
    col, row, depth = pixel_of(seam.points_m, T_base_camera, intrinsics)
    in_image = (depth > 0) & (col > -0.5) & (col < intrinsics.width - 0.5) & (row > -0.5) & (
        row < intrinsics.height - 0.5
    )
    rays = seam.points_m - camera
    distance = np.linalg.norm(rays, axis=1)
    directions = rays / distance[:, None]
    t_hit, _ = cast_rays(scene.mesh if scene.occluder is None else scene.occluder, camera,
                         directions)
    unoccluded = t_hit >= distance - occlusion_tolerance_m
    facing = np.sum(directions * seam.torch_axes, axis=1) > np.cos(np.radians(max_view_angle_deg))
    return in_image & unoccluded & facing


def returned_mask(depth: np.ndarray, seam: TruthSeam, T_base_camera: np.ndarray, intrinsics: Intrinsics) -> np.ndarray:
    """(M,) bool: truth points near whose pixel the sensor returned a depth (any of the 3 x 3
    pixels around it valid in `depth`, 0 = no data). A stretch of seam inside one of the sensor's
    holes was not observed, whatever the mesh would show there."""
    col, row, z = pixel_of(seam.points_m, T_base_camera, intrinsics)
    col, row = np.round(col), np.round(row)
    inside = (z > 0) & (col >= 0) & (col < depth.shape[1]) & (row >= 0) & (row < depth.shape[0])
    col, row = np.where(inside, col, 0).astype(int), np.where(inside, row, 0).astype(int)
    returned = np.zeros(len(z), bool)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            r, c = np.clip(row + dr, 0, depth.shape[0] - 1), np.clip(col + dc, 0, depth.shape[1] - 1)
            returned |= depth[r, c] > 0
    return inside & returned


def make_scan(
    scene: SyntheticScene, rng: np.random.Generator, noise: SensorNoise = SensorNoise(),
    T_base_camera: np.ndarray | None = None, intrinsics: Intrinsics = D415,
) -> SyntheticScan:
    """Render `scene` (camera from `default_camera` unless given) and record which truth
    points the camera observed: in its view (visible_mask) and where the sensor returned a depth
    (returned_mask)."""
    if T_base_camera is None:
        T_base_camera = default_camera(scene, rng)
    depth = render_depth(scene.mesh, T_base_camera, intrinsics, rng, noise)
    return SyntheticScan(
        depth=depth,
        intrinsics=intrinsics,
        T_base_camera=T_base_camera,
        points_m=scan_points(depth, intrinsics, T_base_camera),
        camera_origin_m=T_base_camera[:3, 3].copy(),
        visible=tuple(visible_mask(scene, s, T_base_camera, intrinsics) & returned_mask(depth, s, T_base_camera, intrinsics)
                      for s in scene.seams),
    )
