"""Seam matching and deviations between two path sets, against paths whose differences are known."""

import numpy as np
from scipy.spatial.transform import Rotation

from weldseam.compare import compare_paths, point_to_polyline
from weldseam.geometry import frames_from_axes
from weldseam.types import WeldPath


def straight(seam_id=0, start=(0.0, 0.0, 0.0), length_m=0.1, tilt_deg=0.0, closed=False):
    x = np.arange(0.0, length_m + 1e-12, 0.002)
    positions = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]) + start
    axis = Rotation.from_euler("x", tilt_deg, degrees=True).apply([0.0, 0.0, -1.0])
    rotations = frames_from_axes(np.tile(axis, (len(x), 1)), np.tile([1.0, 0.0, 0.0], (len(x), 1)))
    return WeldPath(seam_id, positions, rotations, closed=closed)


def test_point_to_polyline_is_exact_on_segments_and_vertices():
    polyline = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    points = np.array([[0.5, 0.2, 0], [1.3, 0.5, 0], [2.0, 2.0, 0], [-1, 0, 0]])
    assert np.allclose(point_to_polyline(points, polyline), [0.2, 0.3, np.sqrt(2), 1.0])
    assert np.isclose(point_to_polyline(np.array([[0.5, 0.6, 0]]), polyline, closed=True)[0], np.sqrt(0.005))


def test_a_path_against_itself_deviates_by_nothing():
    paths = [straight(0), straight(1, start=(0, 0.05, 0))]
    comparison = compare_paths(paths, paths)
    assert comparison.within(0.0, 0.0)
    assert all(seam.max_deviation_m == 0 and seam.max_axis_deviation_deg == 0 for seam in comparison.seams)


def test_a_shift_is_measured_and_judged_against_the_tolerance():
    comparison = compare_paths([straight()], [straight(start=(0, 0.0003, 0))])
    (seam,) = comparison.seams
    assert np.isclose(seam.max_deviation_m, 0.0003) and np.isclose(seam.mean_deviation_m, 0.0003)
    assert comparison.within(0.0005, 1.0) and not comparison.within(0.0002, 1.0)


def test_a_turned_torch_axis_fails_an_angle_tolerance():
    comparison = compare_paths([straight()], [straight(tilt_deg=5.0)])
    assert np.isclose(comparison.seams[0].max_axis_deviation_deg, 5.0)
    assert comparison.within(0.001, 6.0) and not comparison.within(0.001, 3.0)


def test_seams_match_by_geometry_whatever_their_order_ids_and_direction():
    a = [straight(0), straight(1, start=(0, 0.05, 0))]
    flipped = straight(7, start=(0, 0.05, 0))
    b = [WeldPath(3, flipped.positions_m[::-1], flipped.rotations[::-1]), straight(9)]
    comparison = compare_paths(a, b)
    assert {(seam.seam_a, seam.seam_b) for seam in comparison.seams} == {(0, 9), (1, 3)}
    assert comparison.within(1e-9, 1e-6)


def test_a_missing_or_far_seam_is_unmatched_and_fails():
    comparison = compare_paths([straight(0), straight(1, start=(0, 0.05, 0))], [straight(0)])
    assert comparison.count_a == 2 and comparison.count_b == 1
    assert [(seam.seam_a, seam.seam_b) for seam in comparison.seams if not seam.matched] == [(1, None)]
    assert not comparison.within(1.0, 180.0)
    far = compare_paths([straight(0)], [straight(0, start=(0, 0.2, 0))])
    assert not any(seam.matched for seam in far.seams)


def test_a_shorter_seam_reports_its_length_difference():
    (seam,) = compare_paths([straight(length_m=0.1)], [straight(length_m=0.09)]).seams
    assert np.isclose(seam.length_difference_m, 0.01)
    assert np.isclose(seam.max_deviation_m, 0.01)  # its missing end is 10 mm from the other
