"""Midpoint pairing across a band: centre lines of known strips, end caps, gaps inside a cluster."""

import numpy as np

from weldseam.pipeline.pairing import _first_spanning, pair_midpoints

PARAMS = dict(tangent_radius_m=0.006, angle_tolerance_deg=10.0, max_width_m=0.06, width_tolerance=0.25)


def rim_lines(*ys_m: float, length_m: float = 0.12, step_m: float = 0.001) -> np.ndarray:
    x = np.arange(0.0, length_m + 1e-9, step_m)
    return np.vstack([np.column_stack([x, np.full_like(x, y), np.zeros_like(x)]) for y in ys_m])


def test_the_midpoints_of_a_straight_band_lie_on_its_centre_line():
    midpoints, widths = pair_midpoints(rim_lines(-0.008, 0.008), **PARAMS)
    assert len(midpoints) > 150
    assert np.abs(midpoints[:, 1]).max() < 1e-9
    assert np.allclose(widths, 0.016)


def test_rounded_end_caps_do_not_pull_the_centre_line_sideways():
    angles = np.linspace(np.pi / 2, 3 * np.pi / 2, 40)
    cap = np.column_stack([0.008 * np.cos(angles), 0.008 * np.sin(angles), np.zeros_like(angles)])
    rim = np.vstack([rim_lines(-0.008, 0.008), cap, cap * [-1, 1, 1] + [0.12, 0, 0]])
    midpoints, _ = pair_midpoints(rim, **PARAMS)
    assert np.abs(midpoints[:, 1]).max() < 0.001  # no zig-zag toward the caps


def test_rims_facing_each_other_across_a_gap_in_the_cluster_do_not_pair():
    # One cluster made of two bands, y in [-8, 8] mm and [24, 40] mm, with a flat 16 mm strip
    # between them: the strip's edges are rims too, as wide apart as each band.
    rim = rim_lines(-0.008, 0.008, 0.024, 0.040)

    def in_band(points: np.ndarray) -> np.ndarray:
        y = points[:, 1]
        return (np.abs(y) <= 0.008) | ((y >= 0.024) & (y <= 0.040))

    unchecked, _ = pair_midpoints(rim, **PARAMS)
    assert np.any(np.abs(unchecked[:, 1] - 0.016) < 1e-9)  # without the check: a false centre line
    midpoints, _ = pair_midpoints(rim, **PARAMS, in_band=in_band)
    centres = np.round(midpoints[:, 1], 6)
    assert set(np.unique(centres)) == {0.0, 0.032}


def test_a_rim_point_pairs_with_its_nearest_candidate_that_spans_the_band():
    # Rim points on a line at x = 0..9; point 0's candidates are 1..8 (nearest first), point 9's
    # only candidate is 8, and point 4's only candidate is 9.
    rim = np.column_stack([np.arange(10.0), np.zeros(10), np.zeros(10)])
    rows, cols = np.array([0] * 8 + [4, 9]), np.array([1, 2, 3, 4, 5, 6, 7, 8, 9, 8])
    starts = np.array([0, 8, 9])

    def in_band(points: np.ndarray) -> np.ndarray:
        # Point 0's samples at 1/4 of the way to a candidate c lie at c / 4: in the band from c = 5.
        return (points[:, 0] >= 1.2) & (points[:, 0] <= 8.6)

    partner = _first_spanning(rim, rows, cols, starts, in_band)
    assert cols[partner].tolist() == [5, 9]  # 0 -> 5 (1, 2, 3 and 4 fail); 9 -> 8 fails (sample at 8.75)
