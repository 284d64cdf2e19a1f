"""Curved faces meeting at a shallow angle: two tube-like surfaces that meet in a concave
valley of 120-150 deg included angle, like the Y-shaped part of the thesis the method comes
from. Joints are not only planar faces at 60-90 deg.

The valley is an inside corner: its truth follows the fillet's convention (`joint` "fillet"),
the seam point on the valley line, the torch axis minus the bisector of the two surfaces'
outward normals there. Units: metres and degrees (parameters); base frame z up.
"""

from __future__ import annotations

import numpy as np

from weldseam.geometry import unit
from weldseam.synthetic.scenes import (
    SEAM_SPACING_M, UP, SyntheticScene, _curve_section_frames, _draw, _line, _scene, _seam,
    _swept_solid, _yaw,
)

FINE_STEP_M = 0.0005  # profile sampling within 10 mm of the valley
COARSE_STEP_M = 0.0015  # and beyond it


def _arc_offsets(start_m: float, end_m: float) -> np.ndarray:
    """Offsets from start_m to end_m (same sign, |start| < |end|), every FINE_STEP_M up to
    10 mm from 0 and every COARSE_STEP_M beyond, both ends included."""
    sign = np.sign(end_m)
    fine_end = min(abs(end_m), 0.010)
    fine = np.linspace(abs(start_m), fine_end, int(np.ceil((fine_end - abs(start_m)) / FINE_STEP_M)) + 1)
    coarse = np.linspace(fine_end, abs(end_m), int(np.ceil((abs(end_m) - fine_end) / COARSE_STEP_M)) + 1)
    return sign * np.r_[fine, coarse[1:]]


def valley_profile(radii_m, slopes_deg, valley_height_m, min_height_m=0.005, max_far_deg=70.0):
    """Cross-section (offsets, heights) of two circular arcs meeting at offset 0, height
    valley_height_m, each sloping down into the valley by its slope (deg from horizontal):
    arc k has radius radii_m[k] and centre (side_k radius sin(slope), valley_height_m -
    radius cos(slope)), side -1 for the first (left), +1 for the second. Each arc runs over
    its crest and down its far side to `max_far_deg` from vertical, or until it is
    `min_height_m` above the table. Also returns the two outward unit normals at the valley,
    as (across, up) pairs."""
    offsets, heights, normals = [], [], []
    for side, radius, slope in zip((-1.0, 1.0), radii_m, np.radians(slopes_deg)):
        centre_u = side * radius * np.sin(slope)
        centre_z = valley_height_m - radius * np.cos(slope)
        far = min(np.radians(max_far_deg),
                  np.arccos(np.clip((min_height_m - centre_z) / radius, -1.0, 1.0)))
        u = _arc_offsets(0.0, centre_u + side * radius * np.sin(far))
        offsets.append(u)
        heights.append(centre_z + np.sqrt(np.maximum(radius**2 - (u - centre_u) ** 2, 0.0)))
        normals.append(np.array([-side * np.sin(slope), np.cos(slope)]))
    offsets_m = np.r_[offsets[0][::-1], offsets[1][1:]]
    heights_m = np.r_[heights[0][::-1], heights[1][1:]]
    return offsets_m, heights_m, normals


def valley(
    rng: np.random.Generator, *, radii_m=None, slopes_deg=None, valley_height_m=None,
    length_m=None, bend_radius_m=None, yaw_deg=None,
) -> SyntheticScene:
    """Two tube-like surfaces (radii 25-60 mm) meeting in a concave valley: each slopes
    15-30 deg into it (included angle 120-150 deg), the valley 25-45 mm above the table,
    150-220 mm long, straight or (half the seeds) bent in plan along an arc of 250-600 mm
    radius (`bend_radius_m`; 0 for straight). Seam: the valley line; torch axis: minus the
    bisector of the two outward normals."""
    radii = rng.uniform(0.025, 0.06, 2) if radii_m is None else np.asarray(radii_m, float)
    slopes = rng.uniform(15.0, 30.0, 2) if slopes_deg is None else np.asarray(slopes_deg, float)
    height = _draw(rng, valley_height_m, 0.025, 0.045)
    length = _draw(rng, length_m, 0.15, 0.22)
    if bend_radius_m is None:
        bend_radius_m = float(rng.uniform(0.25, 0.6)) if rng.integers(2) else 0.0
    offsets, heights, (left, right) = valley_profile(radii, slopes, height)
    if bend_radius_m > 0:
        angles = np.linspace(-0.5, 0.5, int(np.ceil(length / SEAM_SPACING_M)) + 1) * length / bend_radius_m
        curve = bend_radius_m * np.column_stack([np.sin(angles), np.cos(angles) - 1.0])
        origins, across = _curve_section_frames(curve)
        valley_line = origins + height * UP
    else:
        # A straight sweep is a ruled surface: its two end sections make it exactly.
        origins = np.array([[-length / 2, 0.0, 0.0], [length / 2, 0.0, 0.0]])
        across = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
        valley_line = _line([-length / 2, 0.0, height], [length / 2, 0.0, height])
    solid = _swept_solid(origins, across, np.broadcast_to(UP, origins.shape), offsets, heights,
                         0.0, closed=False)
    along_across = across if len(across) == len(valley_line) else np.broadcast_to(across[0], valley_line.shape)
    bisector = (left[0] + right[0]) * along_across + (left[1] + right[1]) * UP
    seam = _seam(valley_line, -unit(bisector), "fillet")
    target = valley_line[len(valley_line) // 2]
    return _scene("valley", [solid], [seam], target, _yaw(rng, yaw_deg),
                  view_axis=unit(bisector[len(bisector) // 2]))
