"""Pipe joints: a pipe standing on a plate (ring fillet at its foot) and a saddle (a branch
pipe set on a main pipe at 90 deg).

Both seams are inside corners between two surfaces, so their truth follows the fillet's
convention and their `joint` is "fillet": the seam point is on the corner curve, the torch
axis minus the bisector of the two surfaces' outward normals (it turns along the curve).
The truth is the whole closed curve; `visible_mask` marks the arc one frame sees. Pipes are
closed at the top by a flush cap, so the only inside corner is the seam.
Units: metres and degrees (parameters); base frame z up, table top at z = 0.
"""

from __future__ import annotations

import numpy as np
import trimesh

from weldseam.geometry import unit
from weldseam.synthetic.scenes import (
    SEAM_SPACING_M, UP, SyntheticScene, _box, _circle, _draw, _scene, _seam, _swept_solid,
    _yaw,
)


def _capped_tube(radial, radius_m, wall_m, base_m, top_m, cap_m=0.003):
    """A vertical tube around the z axis (outer radius radius_m, wall wall_m) sampled at the
    unit directions `radial` (I, 3), from base_m (number, or (I, 2): the bottom's height at
    each direction's inner and outer wall) up to top_m, closed by a cap `cap_m` thick that
    fills its bore flush with the top (the cap's sides are the bore's own facets)."""
    tube = _swept_solid(np.zeros_like(radial), radial, np.broadcast_to(UP, radial.shape),
                        [radius_m - wall_m, radius_m], [top_m, top_m], base_m, closed=True)
    bore = (radius_m - wall_m) * radial
    cap = trimesh.convex.convex_hull(np.vstack([bore + [0, 0, top_m], bore + [0, 0, top_m - cap_m]]))
    return [tube, cap]


def _view_from(azimuth_rad: float, tilt_deg: float) -> np.ndarray:
    """Unit direction tilt_deg from vertical toward the horizontal azimuth."""
    tilt = np.radians(tilt_deg)
    return np.array([np.sin(tilt) * np.cos(azimuth_rad), np.sin(tilt) * np.sin(azimuth_rad),
                     np.cos(tilt)])


def pipe_on_plate(
    rng: np.random.Generator, *, radius_m=None, wall_m=None, height_m=None,
    plate_thickness_m=None, plate_margin_m=None, view_azimuth_deg=None, yaw_deg=None,
) -> SyntheticScene:
    """A pipe (outer radius 25-60 mm, wall 3-8 mm, 60-150 mm tall, capped) standing on a
    square plate (6-12 mm thick, reaching 30-60 mm beyond the pipe) on the table. Seam: the
    ring fillet at the pipe's foot, closed; torch axis minus the bisector of the plate's
    normal and the pipe's outward normal (45 deg down toward the axis). The camera looks
    from 40 deg off vertical, toward a random side (`view_azimuth_deg`)."""
    radius = _draw(rng, radius_m, 0.025, 0.06)
    wall = _draw(rng, wall_m, 0.003, 0.008)
    height = _draw(rng, height_m, 0.06, 0.15)
    plate_t = _draw(rng, plate_thickness_m, 0.006, 0.012)
    half = radius + _draw(rng, plate_margin_m, 0.03, 0.06)
    azimuth = np.radians(_draw(rng, view_azimuth_deg, 0.0, 360.0))
    plate = _box([-half, -half, 0.0], [half, half, plate_t])
    radial = _circle(radius)
    pipe = _capped_tube(radial, radius, wall, plate_t, plate_t + height)
    seam = _seam(radius * radial + [0.0, 0.0, plate_t], -(radial + UP), "fillet", closed=True)
    facing = np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
    return _scene("pipe_on_plate", [plate, *pipe], [seam], radius * facing + [0, 0, plate_t],
                  _yaw(rng, yaw_deg), view_axis=_view_from(azimuth, 40.0), max_view_tilt_deg=10.0)


def saddle_curve(branch_radius_m: float, main_radius_m: float, angles_rad: np.ndarray):
    """Where a vertical cylinder (radius r, axis z) meets a horizontal one (radius R, axis x
    at height R): points (r cos a, r sin a, R + sqrt(R^2 - r^2 sin^2 a)) (A, 3), and the
    two outward normals there, the branch's (cos a, sin a, 0) and the main pipe's
    (0, y, z - R) / R, each (A, 3)."""
    r, big = branch_radius_m, main_radius_m
    y = r * np.sin(angles_rad)
    z = big + np.sqrt(big**2 - y**2)
    points = np.column_stack([r * np.cos(angles_rad), y, z])
    branch_normals = np.column_stack([np.cos(angles_rad), np.sin(angles_rad), np.zeros_like(y)])
    main_normals = np.column_stack([np.zeros_like(y), y, z - big]) / big
    return points, branch_normals, main_normals


def saddle(
    rng: np.random.Generator, *, main_radius_m=None, main_wall_m=None, main_length_m=None,
    branch_ratio=None, branch_wall_m=None, branch_height_m=None, view_azimuth_deg=None,
    yaw_deg=None,
) -> SyntheticScene:
    """A main pipe (outer radius 45-80 mm, wall 5-10 mm, 200-300 mm long along x) lying on
    the table, and a branch pipe (radius 35-65 % of the main's, at least 18 mm; wall 3-6 mm;
    capped 50-100 mm above the main pipe's top) standing on it at 90 deg, its bottom
    following the main pipe's surface. Seam: the closed 3-D intersection curve; torch axis
    minus the bisector of the two pipes' outward normals. The camera looks from 30 deg off
    vertical toward a random side."""
    big = _draw(rng, main_radius_m, 0.045, 0.08)
    main_wall = _draw(rng, main_wall_m, 0.005, 0.010)
    main_length = _draw(rng, main_length_m, 0.20, 0.30)
    small = max(0.018, _draw(rng, branch_ratio, 0.35, 0.65) * big)
    branch_wall = _draw(rng, branch_wall_m, 0.003, 0.006)
    top = 2 * big + _draw(rng, branch_height_m, 0.05, 0.10)
    azimuth = np.radians(_draw(rng, view_azimuth_deg, 0.0, 360.0))
    around_x = _circle(big)[:, [2, 0, 1]]  # circles in the y-z plane: the main pipe's axis is x
    centre = np.array([0.0, 0.0, big])
    main = _swept_solid(np.broadcast_to(centre, around_x.shape),
                        np.broadcast_to([1.0, 0.0, 0.0], around_x.shape), around_x,
                        [-main_length / 2, main_length / 2], [big, big], big - main_wall,
                        closed=True)
    # Angles dense enough that the 3-D curve is sampled every <= SEAM_SPACING_M.
    fine = np.linspace(0.0, 2 * np.pi, 4001)
    points, _, _ = saddle_curve(small, big, fine)
    arc_length = np.linalg.norm(np.diff(points, axis=0), axis=1).max() * (len(fine) - 1)
    angles = np.linspace(0.0, 2 * np.pi, int(np.ceil(1.02 * arc_length / SEAM_SPACING_M)),
                         endpoint=False)
    points, branch_normals, main_normals = saddle_curve(small, big, angles)
    radial = branch_normals
    walls = np.array([small - branch_wall, small])
    base = big + np.sqrt(big**2 - (walls[None, :] * np.sin(angles)[:, None]) ** 2)
    branch = _capped_tube(radial, small, branch_wall, base, top)
    seam = _seam(points, -unit(branch_normals + main_normals), "fillet", closed=True)
    target = points[np.argmax(points[:, :2] @ [np.cos(azimuth), np.sin(azimuth)])]
    return _scene("saddle", [main, *branch], [seam], target, _yaw(rng, yaw_deg),
                  view_axis=_view_from(azimuth, 30.0), max_view_tilt_deg=10.0)
