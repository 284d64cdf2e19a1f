"""Curved inside corners: the ring fillet of a pipe on a plate, the saddle of a branch on a
main pipe, the shallow valley between two tube-like surfaces. Each truth point lies on the
rendered surfaces, and its torch axis is minus the bisector of the two surfaces' normals."""

import numpy as np
import pytest

from tests.synthetic.checks import distance_to_mesh
from weldseam.geometry import unit
from weldseam.synthetic.pipes import pipe_on_plate, saddle, saddle_curve
from weldseam.synthetic.scenes import make_scan
from weldseam.synthetic.sensor import cast_rays
from weldseam.synthetic.valley import valley, valley_profile

SEEDS = range(4)


def _angle_deg(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.degrees(np.arccos(np.clip(np.sum(unit(a) * unit(b), axis=-1), -1.0, 1.0)))


@pytest.mark.parametrize("family", [pipe_on_plate, saddle, valley])
@pytest.mark.parametrize("seed", SEEDS)
def test_corner_truth_lies_on_both_surfaces_and_the_torch_reaches_it(family, seed):
    scene = family(np.random.default_rng(seed))
    (seam,) = scene.seams
    assert seam.joint == "fillet"
    points, axes = seam.points_m[::25], seam.torch_axes[::25]
    assert distance_to_mesh(scene.mesh, points).max() < 1e-6
    # From 3 mm back along the torch axis nothing is in the way before the corner (an open
    # seam's first point is on the part's end face, where the ray would only graze it).
    if not seam.closed:
        points, axes = points[1:], axes[1:]
    t_hit, _ = cast_rays(scene.mesh, points - 0.003 * axes, axes)
    assert np.allclose(t_hit, 0.003, atol=2e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_pipe_on_plate_ring_is_the_pipes_foot_with_the_torch_at_45_deg(seed):
    scene = pipe_on_plate(np.random.default_rng(seed), radius_m=0.04, plate_thickness_m=0.01,
                          yaw_deg=0.0)
    (seam,) = scene.seams
    assert seam.closed
    assert np.allclose(np.linalg.norm(seam.points_m[:, :2], axis=1), 0.04)
    assert np.allclose(seam.points_m[:, 2], 0.01)
    radial = unit(seam.points_m * [1, 1, 0])
    assert np.allclose(_angle_deg(-seam.torch_axes, [0, 0, 1]), 45.0)
    assert np.allclose(_angle_deg(-seam.torch_axes, radial), 45.0)


@pytest.mark.parametrize("seed", SEEDS)
def test_saddle_truth_is_the_intersection_curve_with_a_turning_bisector(seed):
    scene = saddle(np.random.default_rng(seed), main_radius_m=0.06, branch_ratio=0.5,
                   yaw_deg=0.0)
    (seam,) = scene.seams
    points = seam.points_m
    assert seam.closed
    assert np.allclose(np.hypot(points[:, 0], points[:, 1]), 0.03)  # on the branch
    assert np.allclose(np.hypot(points[:, 1], points[:, 2] - 0.06), 0.06)  # on the main pipe
    assert np.linalg.norm(np.diff(points, axis=0), axis=1).max() <= 0.0005
    _, branch, main = saddle_curve(0.03, 0.06, np.arctan2(points[:, 1], points[:, 0]))
    to_branch = _angle_deg(-seam.torch_axes, branch)
    assert np.allclose(to_branch, _angle_deg(-seam.torch_axes, main))  # the bisector
    assert np.allclose(to_branch, _angle_deg(branch, main) / 2)
    assert np.ptp(to_branch) > 10.0  # the corner's angle, and the axis, turn along the curve


def test_one_frame_sees_only_an_arc_of_a_ring():
    rng = np.random.default_rng(4)
    for family in (pipe_on_plate, saddle):
        scene = family(rng)
        visible = make_scan(scene, rng).visible[0]
        assert 0.25 < visible.mean() < 0.75
        # The seen part is one arc: the mask changes value twice around the loop.
        assert np.count_nonzero(visible != np.roll(visible, 1)) == 2


@pytest.mark.parametrize("seed", SEEDS)
def test_valley_meets_at_120_to_150_deg_with_the_bisecting_torch(seed):
    scene = valley(np.random.default_rng(seed))
    (seam,) = scene.seams
    points, axes = seam.points_m, seam.torch_axes
    # The two faces' directions away from the valley, read off the mesh: hits of rays along
    # the torch axis 1 mm to either side.
    for index in np.linspace(0.2, 0.8, 4).astype(float) * (len(points) - 1):
        index = int(index)
        tangent = unit(points[index + 1] - points[index - 1])
        across = unit(np.cross(tangent, axes[index]))
        sides = []
        for side in (-1.0, 1.0):
            origin = points[index] + side * 0.001 * across - 0.01 * axes[index]
            t_hit, _ = cast_rays(scene.mesh, origin[None], axes[index][None])
            sides.append(unit(origin + t_hit[0] * axes[index] - points[index]))
        included = _angle_deg(sides[0], sides[1])
        assert 118.0 < included < 152.0
        # Each face climbs away from the valley equally steeply seen along the torch axis.
        assert _angle_deg(sides[0], -axes[index]) == pytest.approx(_angle_deg(sides[1], -axes[index]), abs=1.5)


def test_valley_profile_is_two_arcs_meeting_at_the_stated_angle():
    offsets, heights, normals = valley_profile([0.03, 0.05], [20.0, 25.0], 0.035)
    at_valley = np.nonzero(offsets == 0.0)[0]
    assert len(at_valley) == 1 and heights[at_valley[0]] == pytest.approx(0.035)
    assert np.all(np.diff(offsets) > 0)
    left, right = offsets < 0, offsets > 0
    centre_left = (-0.03 * np.sin(np.radians(20)), 0.035 - 0.03 * np.cos(np.radians(20)))
    assert np.allclose(np.hypot(offsets[left] - centre_left[0], heights[left] - centre_left[1]), 0.03)
    assert _angle_deg(np.r_[normals[0]], np.r_[normals[1]]) == pytest.approx(45.0)  # 180-135
    assert heights.min() >= 0.005 - 1e-12
