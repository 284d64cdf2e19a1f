"""The curve at a seam's end and the band a corner with one face unseen must lie in (ends.py)."""

import numpy as np

from weldseam.pipeline.ends import end_fit, last_full, on_curve

RADIUS_M = 0.04
AXIS = np.array([0.0, 0.0, -1.0])


def _ring(arc_m: np.ndarray, radial_m: np.ndarray | float = 0.0) -> np.ndarray:
    """Points at arc lengths `arc_m` along a ring of RADIUS_M in z = 0, moved `radial_m` outward."""
    angle = arc_m / RADIUS_M
    reach = RADIUS_M + radial_m
    return np.column_stack([reach * np.cos(angle), reach * np.sin(angle), np.zeros_like(angle)])


def test_the_end_fits_scatter_is_the_rms_distance_from_the_fitted_quadratic():
    arc = np.arange(0.0, 0.040, 0.002)
    clean = end_fit(_ring(arc))[2]
    assert clean < 0.0001  # 46 degrees of a 40 mm ring: a quadratic in arc length to 0.1 mm
    noise = np.where(np.arange(len(arc)) % 2, 0.0003, -0.0003)
    assert 0.0002 <= end_fit(_ring(arc, noise))[2] <= 0.0003 + clean  # of +-0.3 mm, what the fit leaves


def test_a_noisy_ends_band_widens_by_its_scatter():
    # A ring fitted with +-0.4 mm of sideways scatter whose last fit lies 0.8 mm out: the curve at it
    # starts 0.8 mm off and leans, and the ring itself 6 mm on lies over the plain 1 mm band from it.
    arc = np.arange(0.0, 0.040, 0.002)
    noise = np.where(np.arange(len(arc)) % 2, 0.0004, -0.0004)
    noise[-1] = 0.0008
    positions = _ring(arc, noise)
    index, direction, bend, scatter = last_full(positions, None)
    anchor = positions[index]
    on_ring = _ring(np.array([arc[-1] + 0.006]))[0]
    assert not on_curve(anchor, direction, bend, 0.006, on_ring, AXIS)
    assert on_curve(anchor, direction, bend, 0.006, on_ring, AXIS, scatter)
    # The band is still a band: 2.5 mm inside the ring there is off it.
    inside = _ring(np.array([arc[-1] + 0.006]), -0.0025)[0]
    assert not on_curve(anchor, direction, bend, 0.006, inside, AXIS, scatter)
