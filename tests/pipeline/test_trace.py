import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import SectionConfig
from weldseam.geometry import polyline_length
from weldseam.pipeline.trace import TracedSeam, extend_seam

RING_RADIUS_M = 0.05
STEP_M = 0.002
SECTION = SectionConfig()
SECTION_PARAMS = dict(
    half_width_m=SECTION.half_width_m, slab_m=SECTION.slab_m, face_radius_m=SECTION.face_radius_m,
    groove_min_depth_m=SECTION.groove_min_depth_m, fillet_min_leg_m=SECTION.fillet_min_leg_m,
)


def ring_groove_plate(rng, pitch=0.0008, half_open=0.006, depth=0.006):
    """A plate (z = 0 top) with a V-groove around a circle of RING_RADIUS_M, sampled on a grid, 0.1 mm noise."""
    axis = np.arange(-0.085, 0.085, pitch)
    x, y = np.meshgrid(axis, axis)
    across = np.abs(np.hypot(x, y) - RING_RADIUS_M)
    z = -np.clip((half_open - across) * depth / half_open, 0, None) + rng.normal(0, 0.0001, x.shape)
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()])


def ring_arc(start_rad, end_rad):
    angles = np.arange(start_rad, end_rad, STEP_M / RING_RADIUS_M)
    positions = RING_RADIUS_M * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))])
    return TracedSeam(positions, np.tile([0.0, 0.0, -1.0], (len(angles), 1)), False, "v_groove", 1.0)


def test_an_extension_round_a_loop_stops_where_it_meets_the_seam(rng):
    points = ring_groove_plate(rng)
    seam = ring_arc(0.0, 1.5 * np.pi)  # three quarters of the ring traced; the rest is for extension
    extended = extend_seam(seam, points, cKDTree(points), step_m=STEP_M, max_gap_m=0.012, max_extension_m=0.3,
                           section_params=SECTION_PARAMS)  # fmt: skip
    positions = extended.positions_m
    radii = np.hypot(positions[:, 0], positions[:, 1])
    assert np.abs(radii - RING_RADIUS_M).max() < 0.0005, "the extension follows the groove"
    circumference = 2 * np.pi * RING_RADIUS_M
    assert polyline_length(positions) > 0.9 * circumference, "the missing quarter is filled in"
    assert polyline_length(positions) < circumference, "and it does not go round a second time"
    assert np.linalg.norm(positions[0] - positions[-1]) <= 3 * STEP_M, "the ends meet, so the seam can close"
