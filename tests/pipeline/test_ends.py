"""The curve at a seam's end and the band a corner with one face unseen must lie in (ends.py)."""

import numpy as np
import pytest

from weldseam.pipeline.ends import end_fit, last_full, on_curve

RADIUS_M = 0.04
AXIS = np.array([0.0, 0.0, -1.0])


def _ring(arc_m: np.ndarray, radial_m: np.ndarray | float = 0.0, radius_m: float = RADIUS_M) -> np.ndarray:
    """Points at arc lengths `arc_m` along a ring of `radius_m` round the origin in z = 0, moved
    `radial_m` outward."""
    angle = arc_m / radius_m
    reach = radius_m + radial_m
    return np.column_stack([reach * np.cos(angle), reach * np.sin(angle), np.zeros_like(angle)])


def test_the_end_fits_scatter_is_the_rms_distance_from_the_fitted_quadratic():
    arc = np.arange(0.0, 0.040, 0.002)
    clean = end_fit(_ring(arc))[2]
    assert clean < 0.0001  # 46 degrees of a 40 mm ring: a quadratic in arc length to 0.1 mm
    noise = np.where(np.arange(len(arc)) % 2, 0.0003, -0.0003)
    assert 0.0002 <= end_fit(_ring(arc, noise))[2] <= 0.0003 + clean  # of +-0.3 mm, what the fit leaves


def test_a_noisy_ends_band_widens_by_its_scatter():
    # A straight seam fitted with +-0.4 mm of sideways scatter (no bend: no inside to lag toward):
    # 6 mm on, 1.5 mm sideways lies past the plain 1 mm band and within the one widened by the
    # scatter; 2.5 mm sideways is off either way.
    arc = np.arange(0.0, 0.040, 0.002)
    scatter_y = np.where(np.arange(len(arc)) % 2, 0.0004, -0.0004)
    positions = np.column_stack([arc, scatter_y, np.zeros_like(arc)])
    index, direction, bend, scatter = last_full(positions, None)
    assert 0.0003 <= scatter <= 0.0005
    anchor = positions[index]
    ahead_6mm = anchor + 0.006 * direction
    for side in (1.0, -1.0):
        near = ahead_6mm + [0.0, side * 0.0015, 0.0]
        assert not on_curve(anchor, direction, bend, 0.006, near, AXIS)
        assert on_curve(anchor, direction, bend, 0.006, near, AXIS, scatter)
        assert not on_curve(anchor, direction, bend, 0.006, ahead_6mm + [0.0, side * 0.0025, 0.0], AXIS, scatter)

def test_a_ring_tighter_than_the_clamped_bend_stays_on_the_curve_and_its_tangent_does_not():
    # A 25 mm ring (a saddle on a branch pipe of 50 mm): the end curve's bend is clamped at 30 mm,
    # so the ring runs inside it, 3.1 mm 20 mm on, 1.5 times the plain band or more; a shadow's
    # edge leaves the ring along its tangent and is off the curve once it leaves the ring by 2 mm.
    radius = 0.025
    arc = np.arange(0.0, 0.032, 0.002)
    index, direction, bend, scatter = last_full(_ring(arc, radius_m=radius), None)
    assert 1 / np.linalg.norm(bend) == pytest.approx(0.030, rel=0.01)  # clamped
    anchor = _ring(arc[-1:], radius_m=radius)[0]
    tangent = np.array([-np.sin(arc[-1] / radius), np.cos(arc[-1] / radius), 0.0])
    for on in (0.004, 0.008, 0.012, 0.016, 0.020):
        ahead_arc = np.array([arc[-1] + on])
        assert on_curve(anchor, direction, bend, on, _ring(ahead_arc, radius_m=radius)[0], AXIS, scatter)
        # Farther inside than a 17 mm ring lags behind the curve: off it.
        deeper = _ring(ahead_arc, -0.004, radius_m=radius)[0]
        assert not on_curve(anchor, direction, bend, on, deeper, AXIS, scatter)
    for on in (0.016, 0.020):
        assert not on_curve(anchor, direction, bend, on, anchor + on * tangent, AXIS, scatter)
    # Outside the ring by more than the band is off it, and so is the ring 5 mm farther along than
    # the arc says (the fits must keep pace with the curve).
    assert not on_curve(anchor, direction, bend, 0.008, _ring(np.array([arc[-1] + 0.008]), 0.0025, radius_m=radius)[0],
                        AXIS, scatter)  # fmt: skip
    assert not on_curve(anchor, direction, bend, 0.008, _ring(np.array([arc[-1] + 0.013]), radius_m=radius)[0],
                        AXIS, scatter)  # fmt: skip
    # The plain band alone would lose the ring 20 mm on.
    predicted = anchor + 0.020 * direction + 0.5 * 0.020**2 * bend
    band = max(0.001 + 2 * scatter, 0.08 * 0.020)
    assert np.linalg.norm(_ring(np.array([arc[-1] + 0.020]), radius_m=radius)[0] - predicted) > 1.5 * band


def test_a_wide_rings_curve_follows_it_and_gives_no_room_inside():
    # A 60 mm ring (a pipe standing on a plate) fits at 62 mm: no tighter ring hides in that curve,
    # and 2.5 mm inside the ring 16 mm on is off it, as 2.5 mm outside is.
    radius = 0.060
    arc = np.arange(0.0, 0.032, 0.002)
    index, direction, bend, scatter = last_full(_ring(arc, radius_m=radius), None)
    assert 1 / np.linalg.norm(bend) == pytest.approx(radius, rel=0.05)
    anchor = _ring(arc[-1:], radius_m=radius)[0]
    ahead_arc = np.array([arc[-1] + 0.016])
    assert on_curve(anchor, direction, bend, 0.016, _ring(ahead_arc, radius_m=radius)[0], AXIS, scatter)
    for radial in (-0.0025, 0.0025):
        assert not on_curve(anchor, direction, bend, 0.016, _ring(ahead_arc, radial, radius_m=radius)[0], AXIS, scatter)
