"""Plate joints beyond the V-groove and the T fillet: lap, single bevel, square butt, outside
corner, tack welds on a V-groove, and a seam among clamps and loose bars.

Truth conventions (those of the independent scans in ../shared/foreign): a groove's seam
point is the centre of its opening at the surface (the midpoint of the two top edges) with
the torch along the negated plate normal; an inside corner's (lap, fillet) is on the corner
line with the torch along minus the bisector of the two face normals; an outside corner's is
the centre of its V's opening with the torch along minus the bisector. Plate joints lying
flat may rest on the table, a wedge or two blocks (`mount`, see fixtures.rest_on_support).
Units: metres and degrees (parameters); base frame z up, table top at z = 0.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import trimesh

from weldseam.synthetic.fixtures import add_clutter, rest_on_support
from weldseam.synthetic.scenes import (
    UP, SyntheticScene, Tack, TruthSeam, _box, _butt_plates, _convex_solid, _draw,
    _draw_groove, _line, _moved, _plate_piece, _rotation, _scene, _seam, _VGroove, _yaw,
    fillet_t, v_butt,
)

MOUNTS = ("table", "table", "wedge", "blocks")  # drawn uniformly: half on the table


def _y_bounds(length_m: float) -> list:
    """Bounds (for _plate_piece) |y| <= length_m / 2."""
    return [((0.0, 1.0), length_m / 2), ((0.0, -1.0), length_m / 2)]


def _placed(name, parts, seams, rng, mount, yaw_deg, *, fixtures=(), hidden=(), view_axis=UP,
            max_view_tilt_deg=30.0, target_m=None) -> SyntheticScene:
    """Scene of a workpiece lying flat on z = 0: on the table, or tilted onto a wedge or two
    blocks (`mount`, drawn from MOUNTS when None), then turned by `yaw_deg`. The camera
    looks at `target_m` (default: the middle of the first seam) along `view_axis` (both
    given flat, moved with the workpiece)."""
    mount = str(rng.choice(MOUNTS)) if mount is None else mount
    view = np.asarray(view_axis, float)
    target = None if target_m is None else np.asarray(target_m, float)
    if mount != "table":
        supported = rest_on_support([*parts, *fixtures], seams, rng, mount)
        count = len(parts)
        parts, seams = supported.parts[:count], supported.seams
        fixtures = [*supported.parts[count:], *supported.supports]
        view = supported.move[:3, :3] @ view
        target = None if target is None else supported.move[:3, :3] @ target + supported.move[:3, 3]
    if target is None:
        target = seams[0].points_m[len(seams[0].points_m) // 2]
    return _scene(name, parts, seams, target, _yaw(rng, yaw_deg), view, max_view_tilt_deg,
                  fixtures=fixtures, hidden=hidden)


def lap(
    rng: np.random.Generator, *, bottom_thickness_m=None, top_thickness_m=None, overlap_m=None,
    length_m=None, bottom_width_m=None, top_width_m=None, torch_split_deg=45.0, mount=None,
    yaw_deg=None,
) -> SyntheticScene:
    """Lap joint: a top plate (2-6 mm thick, 70-100 mm wide) lying on a bottom plate (4-12 mm,
    70-100 mm wide) with 25-50 mm of overlap, both 150-220 mm long along y; the top plate's
    far end rests on a spacer block as thick as the bottom plate (a fixture).

    Seam: the inside corner where the top plate's edge (x = 0) meets the bottom plate's top.
    Torch axis: across the seam, `torch_split_deg` from the bottom plate's surface, into the
    corner. 45 is the bisector of the two face normals, the convention of the independent
    scans, and the geometric truth a planner measures; welding practice tilts it to ~60 deg
    (toward the bottom plate), which is torch shaping on top of the measured corner.
    The top plate's edge hides the corner from its own side, so the camera looks from 25 deg
    off the plates' normal toward the open side (within 15 deg).
    """
    bottom_t = _draw(rng, bottom_thickness_m, 0.004, 0.012)
    top_t = _draw(rng, top_thickness_m, 0.002, 0.006)
    overlap = _draw(rng, overlap_m, 0.025, 0.05)
    length = _draw(rng, length_m, 0.15, 0.22)
    bottom_w = _draw(rng, bottom_width_m, 0.07, 0.10)
    top_w = _draw(rng, top_width_m, 0.07, 0.10)
    half = length / 2
    bottom = _box([overlap - bottom_w, -half, 0.0], [overlap, half, bottom_t])
    top = _box([0.0, -half, bottom_t], [top_w, half, bottom_t + top_t])
    spacer_w = min(0.02, top_w - overlap - 0.01)
    spacer = _box([top_w - spacer_w, -half, 0.0], [top_w, half, bottom_t])
    split = np.radians(torch_split_deg)
    seam = _seam(_line([0.0, -half, bottom_t], [0.0, half, bottom_t]),
                 [np.cos(split), 0.0, -np.sin(split)], "lap")
    view = [-np.sin(np.radians(25.0)), 0.0, np.cos(np.radians(25.0))]
    return _placed("lap", [bottom, top], [seam], rng, mount, yaw_deg, fixtures=[spacer],
                   view_axis=view, max_view_tilt_deg=15.0)


def lap_and_fillet(
    rng: np.random.Generator, *, base_thickness_m=None, top_thickness_m=None, reach_m=None,
    web_thickness_m=None, web_height_m=None, gap_m=None, length_m=None, torch_split_deg=45.0,
    mount=None, yaw_deg=None,
) -> SyntheticScene:
    """A lap and a fillet in one view: a top plate (2-6 mm thick) lying on a base plate (8-11
    mm: an edge on the table stays under a fillet's shortest face and over a lap's tallest
    step), its edge along y at x = 0 and the base plate reaching 30-50 mm beyond it (x > 0);
    on the top plate a web (6-12 mm thick, 30-60 mm high) stands 55-90 mm back from that
    edge, facing it. The web's back, the top plate's and the base plate's far edges are
    flush (x = -gap - web thickness): one lap corner and one fillet, both open toward +x.
    All 150-220 mm long along y.

    Seams: the lap's inside corner (x = 0, torch `torch_split_deg` from the base plate, as in
    `lap`) and the fillet where the web meets the top plate (x = -gap, torch along minus the
    bisector). Both are seen from their open side: the camera looks at the middle between
    them from 30 deg off the plates' normal toward +x (within 15 deg).
    """
    base_t = _draw(rng, base_thickness_m, 0.008, 0.011)
    top_t = _draw(rng, top_thickness_m, 0.002, 0.006)
    reach = _draw(rng, reach_m, 0.03, 0.05)
    web_t = _draw(rng, web_thickness_m, 0.006, 0.012)
    web_h = _draw(rng, web_height_m, 0.03, 0.06)
    gap = _draw(rng, gap_m, 0.055, 0.09)
    length = _draw(rng, length_m, 0.15, 0.22)
    half, back, top_z = length / 2, -gap - web_t, base_t + top_t
    base = _box([back, -half, 0.0], [reach, half, base_t])
    top = _box([back, -half, base_t], [0.0, half, top_z])
    web = _box([back, -half, top_z], [-gap, half, top_z + web_h])
    split = np.radians(torch_split_deg)
    seams = [
        _seam(_line([0.0, -half, base_t], [0.0, half, base_t]), [-np.cos(split), 0.0, -np.sin(split)], "lap"),
        _seam(_line([-gap, -half, top_z], [-gap, half, top_z]), [-1.0, 0.0, -1.0], "fillet"),
    ]
    view = [np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0))]
    return _placed("lap_and_fillet", [base, top, web], seams, rng, mount, yaw_deg, view_axis=view,
                   max_view_tilt_deg=15.0, target_m=[-gap / 2, 0.0, top_z])


def v_groove_and_square_butt(
    rng: np.random.Generator, *, thickness_m=None, included_angle_deg=None, root_gap_m=None,
    root_face_m=None, square_gap_m=None, separation_m=None, length_m=None, mount=None, yaw_deg=None,
) -> SyntheticScene:
    """A V-groove and a square butt in one plate row: three plates (6-8 mm thick, 150-220 mm
    long along y) side by side, the first two joined by a single V (included angle 60-90 deg,
    root gap 0-2 mm, root face 0.5-2 mm) along x = -separation / 2, the last two by square
    edges 0.8-3 mm apart along x = +separation / 2, 70-100 mm between the seams; the outer
    plates 50-70 mm wide. Seams: the V's and the gap's centre lines at the surface, torch
    axis minus the plate normal; the camera looks at the middle between them."""
    thickness = _draw(rng, thickness_m, 0.006, 0.008)
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    root_face = _draw(rng, root_face_m, 0.0005, 0.002)
    gap = _draw(rng, square_gap_m, 0.0008, 0.003)
    separation = _draw(rng, separation_m, 0.07, 0.10)
    length = _draw(rng, length_m, 0.15, 0.22)
    outer = [_draw(rng, None, 0.05, 0.07) for _ in range(2)]
    v_x, butt_x, half = -separation / 2, separation / 2, length / 2
    first = _plate_piece(thickness, [((-1.0, 0.0), -v_x + outer[0]), *_y_bounds(length)],
                         [((v_x, 0.0), (-1.0, 0.0))], groove, root_face)
    middle = _plate_piece(thickness, [((1.0, 0.0), butt_x - gap / 2), *_y_bounds(length)],
                          [((v_x, 0.0), (1.0, 0.0))], groove, root_face)
    last = _box([butt_x + gap / 2, -half, 0.0], [butt_x + gap / 2 + outer[1], half, thickness])
    seams = [
        _seam(_line([v_x, -half, thickness], [v_x, half, thickness]), -UP, "v_groove"),
        _seam(_line([butt_x, -half, thickness], [butt_x, half, thickness]), -UP, "square_butt"),
    ]
    return _placed("v_groove_and_square_butt", [first, middle, last], seams, rng, mount, yaw_deg,
                   target_m=[0.0, 0.0, thickness])


def bevel(
    rng: np.random.Generator, *, thickness_m=None, bevel_angle_deg=None, root_gap_m=None,
    root_face_m=None, length_m=None, plate_width_m=None, mount=None, yaw_deg=None,
) -> SyntheticScene:
    """Single bevel (half V) butt joint: two plates (6-12 mm thick, 60-90 mm wide, 150-220 mm
    long along y), the one at x < 0 with a square edge, the other bevelled 30-50 deg from the
    plate normal above a 0-2 mm root face, root gap 0-2 mm. Seam: the middle of the opening
    at the surface; torch axis: minus the plate normal."""
    thickness = _draw(rng, thickness_m, 0.006, 0.012)
    groove = _VGroove(np.radians(_draw(rng, bevel_angle_deg, 30.0, 50.0)),
                      _draw(rng, root_gap_m, 0.0, 0.002))
    root_face = _draw(rng, root_face_m, 0.0, 0.002)
    length = _draw(rng, length_m, 0.15, 0.22)
    width = _draw(rng, plate_width_m, 0.06, 0.09)
    half_gap = groove.root_gap_m / 2
    square = _plate_piece(thickness, [((1.0, 0.0), -half_gap), ((-1.0, 0.0), half_gap + width),
                                      *_y_bounds(length)], [], groove, root_face)
    bevelled = _plate_piece(thickness, [((1.0, 0.0), half_gap + width), *_y_bounds(length)],
                            [((0.0, 0.0), (1.0, 0.0))], groove, root_face)
    opening_centre = (thickness - root_face) * np.tan(groove.half_angle_rad) / 2
    seam = _seam(_line([opening_centre, -length / 2, thickness],
                       [opening_centre, length / 2, thickness]), -UP, "bevel")
    return _placed("bevel", [square, bevelled], [seam], rng, mount, yaw_deg)


def square_butt(
    rng: np.random.Generator, *, thickness_m=None, root_gap_m=None, length_m=None,
    plate_width_m=None, mount=None, yaw_deg=None,
) -> SyntheticScene:
    """Square butt (I-groove): two plates 3-8 mm thick, 60-90 mm wide, 150-220 mm long along
    y, square edges 0.8-3 mm apart. Seam: the gap's centre line at the surface; torch axis:
    minus the plate normal."""
    thickness = _draw(rng, thickness_m, 0.003, 0.008)
    gap = _draw(rng, root_gap_m, 0.0008, 0.003)
    length = _draw(rng, length_m, 0.15, 0.22)
    width = _draw(rng, plate_width_m, 0.06, 0.09)
    plates = [
        _box([-gap / 2 - width, -length / 2, 0.0], [-gap / 2, length / 2, thickness]),
        _box([gap / 2, -length / 2, 0.0], [gap / 2 + width, length / 2, thickness]),
    ]
    seam = _seam(_line([0.0, -length / 2, thickness], [0.0, length / 2, thickness]), -UP,
                 "square_butt")
    return _placed("square_butt", plates, [seam], rng, mount, yaw_deg)


def _corner_plate(side, thickness_m, slope_length_m, length_m, groove: _VGroove, root_depth_m):
    """One plate of an outside corner (side -1: x < 0), in the frame where the two outer
    faces are z = -|x| (a roof at 90 deg, ridge on the y axis). The plate keeps the slab
    under its outer face, its side of the gap, and the groove flank that leans out from
    the root (x = side * gap / 2, z = -root_depth_m) by the half angle."""
    tan_half = np.tan(groove.half_angle_rad)
    face_normal = np.array([side * np.sqrt(0.5), 0.0, np.sqrt(0.5)])  # outer face, outward
    downhill = np.array([side * np.sqrt(0.5), 0.0, -np.sqrt(0.5)])
    limit = -groove.root_gap_m / 2
    normals = [face_normal, -face_normal, [-side, 0.0, 0.0], [-side, 0.0, tan_half], downhill,
               [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]
    offsets = [0.0, thickness_m, limit, limit - root_depth_m * tan_half, slope_length_m,
               length_m / 2, length_m / 2]
    return _convex_solid(np.array(normals, float), np.array(offsets))


def outside_corner(
    rng: np.random.Generator, *, thickness_m=None, included_angle_deg=None, root_gap_m=None,
    groove_depth_fraction=None, slope_length_m=None, length_m=None, roll_deg=None,
    yaw_deg=None,
) -> SyntheticScene:
    """Outside corner: two plates (4-10 mm thick, 150-220 mm long along y) meeting at 90 deg
    in a convex edge, each edge bevelled so they leave an open V (included angle 50-80 deg,
    root gap 0-1.5 mm, the root 40-70 % of the way from the outer corner to the inner one).
    The pair stands like a roof, rolled -15..15 deg about the ridge, both far edges on the
    table (one slope 50-80 mm long, the other as long as it must be).

    Seam: the centre of the V's opening (midpoint of its two top edges, in the air); torch
    axis: minus the bisector of the two outer face normals."""
    thickness = _draw(rng, thickness_m, 0.004, 0.010)
    groove = _VGroove(np.radians(_draw(rng, included_angle_deg, 50.0, 80.0)) / 2,
                      _draw(rng, root_gap_m, 0.0, 0.0015))
    depth = _draw(rng, groove_depth_fraction, 0.4, 0.7) * thickness * np.sqrt(2.0)
    depth = max(depth, groove.root_gap_m / 2 + 0.0005)
    slope = _draw(rng, slope_length_m, 0.05, 0.08)
    length = _draw(rng, length_m, 0.15, 0.22)
    roll = _rotation([0.0, 1.0, 0.0], np.radians(_draw(rng, roll_deg, -15.0, 15.0)))

    def lowest(side, slope_m):
        plate = _corner_plate(side, thickness, slope_m, length, groove, depth)
        return plate.copy().apply_transform(roll).vertices[:, 2].min()

    first_side = float(rng.choice([-1.0, 1.0]))
    first_low = lowest(first_side, slope)
    # The other plate's lowest point falls linearly with its slope length: solve for the table.
    low_a, low_b = lowest(-first_side, 0.05), lowest(-first_side, 0.10)
    other_slope = 0.05 + (first_low - low_a) * 0.05 / (low_b - low_a)
    plates = [_corner_plate(first_side, thickness, slope, length, groove, depth),
              _corner_plate(-first_side, thickness, other_slope, length, groove, depth)]
    tan_half = np.tan(groove.half_angle_rad)
    edge_z = -(groove.root_gap_m / 2 + depth * tan_half) / (1.0 + tan_half)
    seam = _seam(_line([0.0, -length / 2, edge_z], [0.0, length / 2, edge_z]), -UP,
                 "outside_corner")
    lift = np.eye(4)
    lift[2, 3] = -first_low
    plates, (seam,) = _moved(lift @ roll, plates, [seam])
    target = seam.points_m[len(seam.points_m) // 2]
    return _scene("outside_corner", plates, [seam], target, _yaw(rng, yaw_deg),
                  view_axis=roll[:3, :3] @ UP)


def _tack_solids(seam_x_m, centre_y_m, thickness_m, groove: _VGroove, root_face_m, length_m,
                 height_m, dome_margin_m):
    """A tack on a straight V-groove along y at x = seam_x_m: a filler that fills the groove
    (root gap included) over length_m, and a dome (half ellipsoid, height_m high, as long as
    the tack, as wide as the opening plus dome_margin_m each side) sitting on the surface."""
    half_open = groove.root_gap_m / 2 + (thickness_m - root_face_m) * np.tan(groove.half_angle_rad)
    half_gap = groove.root_gap_m / 2
    section = np.array([[-half_gap, 0.0], [half_gap, 0.0], [half_gap, root_face_m],
                        [half_open, thickness_m], [-half_open, thickness_m], [-half_gap, root_face_m]])
    ends = [centre_y_m - length_m / 2, centre_y_m + length_m / 2]
    filler = trimesh.convex.convex_hull(np.array(
        [[seam_x_m + x, y, z] for y in ends for x, z in section]
    ))
    azimuth = np.linspace(0.0, 2 * np.pi, 48, endpoint=False)
    elevation = np.linspace(0.0, np.pi / 2, 9)[:-1]
    a, e = np.meshgrid(azimuth, elevation)
    semi = np.array([half_open + dome_margin_m, length_m / 2, height_m])
    shell = np.column_stack([(np.cos(e) * np.cos(a)).ravel(), (np.cos(e) * np.sin(a)).ravel(),
                             np.sin(e).ravel()]) * semi
    dome = trimesh.convex.convex_hull(
        np.vstack([shell, [0.0, 0.0, height_m]]) + [seam_x_m, centre_y_m, thickness_m]
    )
    return [filler, dome]


def tacked(
    rng: np.random.Generator, *, tack_count=None, thickness_m=None, included_angle_deg=None,
    root_gap_m=None, root_face_m=None, length_m=None, plate_width_m=None, yaw_deg=None,
) -> SyntheticScene:
    """A v_butt groove (as `v_butt`) with 2-4 tack welds: each 6-12 mm long, its dome
    1.5-3 mm above the surface, the groove under it filled; tacks 20 mm or more apart and
    15 mm or more from the seam's ends. The truth is the groove's centre line, tacks
    included (the path runs across them; the seam under a tack counts as seen where the
    seam would be), and records each tack's centre on the seam, length and height."""
    thickness = _draw(rng, thickness_m, 0.006, 0.012)
    groove = _draw_groove(rng, included_angle_deg, root_gap_m, 0.002)
    root_face = _draw(rng, root_face_m, 0.0005, 0.002)
    length = _draw(rng, length_m, 0.18, 0.22)
    plates, seam = _butt_plates(thickness, groove, root_face, length,
                                _draw(rng, plate_width_m, 0.06, 0.09))
    count = int(rng.integers(2, 5)) if tack_count is None else int(tack_count)
    lengths = rng.uniform(0.006, 0.012, count)
    heights = rng.uniform(0.0015, 0.003, count)
    # Spread the tacks: the free length left after tacks and 20 mm gaps, cut at random.
    free = length - 0.03 - lengths.sum() - 0.02 * (count - 1)
    cuts = np.sort(rng.uniform(0.0, free, count))
    starts = -length / 2 + 0.015 + cuts + np.r_[0.0, np.cumsum(lengths[:-1] + 0.02)]
    centres_y = starts + lengths / 2
    tacks, solids = [], []
    for y, tack_length, height in zip(centres_y, lengths, heights):
        solids += _tack_solids(0.0, y, thickness, groove, root_face, tack_length, height,
                               rng.uniform(0.0005, 0.0015))
        tacks.append(Tack(np.array([0.0, y, thickness]), float(tack_length), float(height)))
    seam = TruthSeam(seam.points_m, seam.torch_axes, seam.closed, seam.joint, tuple(tacks))
    target = [0.0, 0.0, thickness]
    return _scene("tacked", [*plates, *solids], [seam], target, _yaw(rng, yaw_deg),
                  hidden=tuple(range(len(plates), len(plates) + len(solids))))


def clutter(rng: np.random.Generator, *, base=None, clamps=None, bars=None) -> SyntheticScene:
    """A `v_butt`, `lap` or `fillet_t` (`base`, random) lying on the table with 1-3 clamps on
    its plates' edges and 1-3 loose bars on the table (fixtures: never a seam). The seams
    are the base's."""
    base = str(rng.choice(["v_butt", "lap", "fillet_t"])) if base is None else base
    builders = {"v_butt": v_butt, "fillet_t": fillet_t,
                "lap": lambda r: lap(r, mount="table")}
    scene = builders[base](rng)
    clamps = int(rng.integers(1, 4)) if clamps is None else clamps
    bars = int(rng.integers(1, 4)) if bars is None else bars
    scene = add_clutter(scene, rng, clamps=clamps, bars=bars, attempts=200)
    return dataclasses.replace(scene, name=f"clutter({base})")
