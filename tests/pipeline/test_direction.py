"""weldseam.pipeline.direction: the travel direction follows the configured rule, with known answers."""

import numpy as np
import pytest

from weldseam.config import DIRECTION_RULES, DirectionConfig
from weldseam.geometry import frames_from_axes, unit
from weldseam.pipeline.direction import orient_path, orient_paths
from weldseam.types import WeldPath


def open_path(start, end, count=41, torch=(0.0, 0.0, -1.0)) -> WeldPath:
    """A straight path from `start` to `end` with tool y along travel and z = `torch`."""
    positions = np.linspace(start, end, count)
    travel = np.tile(unit(np.subtract(end, start)), (count, 1))
    return WeldPath(0, positions, frames_from_axes(np.tile(torch, (count, 1)), travel), joint="fillet", confidence=0.7)


def ring(centre, radius, normal, count=60, start_deg=37.0) -> WeldPath:
    """A closed circle about `normal`, counter-clockwise about it, first pose at `start_deg`."""
    normal = unit(np.asarray(normal, float))
    u = unit(np.cross(normal, [0.3, 0.5, 0.7]))
    v = np.cross(normal, u)
    angles = np.radians(start_deg) + np.linspace(0, 2 * np.pi, count, endpoint=False)
    positions = np.asarray(centre) + radius * (np.outer(np.cos(angles), u) + np.outer(np.sin(angles), v))
    travel = -np.outer(np.sin(angles), u) + np.outer(np.cos(angles), v)
    return WeldPath(1, positions, frames_from_axes(np.tile(-normal, (count, 1)), travel), closed=True)


def runs_along(path: WeldPath) -> np.ndarray:
    return unit(path.positions_m[-1] - path.positions_m[0])


def assert_consistent_frames(path: WeldPath) -> None:
    """Tool y along travel, right-handed frames (x = y cross z)."""
    steps = np.diff(path.positions_m, axis=0)
    assert (np.sum(steps * path.rotations[:-1, :, 1], axis=1) > 0).all()
    np.testing.assert_allclose(np.linalg.det(path.rotations), 1.0, atol=1e-12)


@pytest.mark.parametrize("rule, heading", [
    ("+x", [1, 1]), ("-x", [-1, -1]),
    ("+y", [1, 1]), ("-y", [-1, -1]),  # 20 degrees from the x axis is 70 from y: y decides
    ("+z", [1, 1]), ("-z", [-1, -1]),  # square to z: the next axis, x, with the rule's sign
])
def test_an_open_seam_runs_along_the_rules_axis(rule, heading):
    backwards = open_path([0.5, 0.1, 0.0], [0.2, 0.1 - 0.3 * np.tan(np.radians(20)), 0.0])  # heads -x and -y
    oriented = orient_path(backwards, DirectionConfig(rule=rule))
    np.testing.assert_array_equal(np.sign(runs_along(oriented)[:2]), heading)
    assert_consistent_frames(oriented)


def test_a_reversed_path_keeps_its_poses_torch_axes_and_metadata():
    path = open_path([0.5, 0.0, 0.0], [0.2, 0.0, 0.0], torch=unit(np.array([0.0, 0.3, -1.0])))
    reversed_path = orient_path(path, DirectionConfig())
    np.testing.assert_array_equal(reversed_path.positions_m, path.positions_m[::-1])
    np.testing.assert_array_equal(reversed_path.rotations[:, :, 2], path.rotations[::-1, :, 2])
    np.testing.assert_array_equal(reversed_path.rotations[:, :, :2], -path.rotations[::-1, :, :2])
    assert (reversed_path.seam_id, reversed_path.joint, reversed_path.confidence) == (0, "fillet", 0.7)
    assert_consistent_frames(reversed_path)


@pytest.mark.parametrize("off_square_deg, runs", [(5.0, "+y"), (9.0, "+y"), (11.0, "+x"), (45.0, "+x")])
def test_a_seam_near_square_to_the_axis_hands_over_to_the_next_axis(off_square_deg, runs):
    """Under +x a seam within 10 degrees of square to x runs +y; beyond, +x (both ways round)."""
    angle = np.radians(90.0 + off_square_deg)  # heading -x a little, and +y
    end = np.array([0.3 + 0.2 * np.cos(angle), 0.2 * np.sin(angle), 0.05])
    for start, finish in (([0.3, 0.0, 0.05], end), (end, [0.3, 0.0, 0.05])):
        oriented = orient_path(open_path(start, finish), DirectionConfig())
        heading = runs_along(oriented)
        assert heading[1 if runs == "+y" else 0] > 0


@pytest.mark.parametrize("rule, starts_at", [("away-from-robot", "near"), ("toward-robot", "far")])
def test_radial_rules_start_at_the_end_nearer_or_farther_from_the_base(rule, starts_at):
    near, far = np.array([0.4, 0.1, 0.02]), np.array([0.6, 0.25, 0.02])
    for start, end in ((near, far), (far, near)):
        oriented = orient_path(open_path(start, end), DirectionConfig(rule=rule))
        np.testing.assert_allclose(oriented.positions_m[0], near if starts_at == "near" else far)


def test_a_start_point_starts_each_seam_at_its_nearest_end():
    point = (0.0, 0.5, 0.0)
    config = DirectionConfig(rule="start-point", start_m=point)
    first = orient_path(open_path([0.2, 0.1, 0.0], [0.2, 0.4, 0.0]), config)
    second = orient_path(open_path([-0.1, 0.45, 0.0], [0.3, 0.45, 0.0]), config)
    np.testing.assert_allclose(first.positions_m[0], [0.2, 0.4, 0.0])
    np.testing.assert_allclose(second.positions_m[0], [-0.1, 0.45, 0.0])


def test_a_horizontal_ring_starts_at_its_minus_x_pose_counter_clockwise_from_above():
    centre = np.array([0.5, 0.0, 0.1])
    for normal in ([0, 0, 1], [0, 0, -1]):
        oriented = orient_path(ring(centre, 0.05, normal), DirectionConfig())
        assert np.argmin(oriented.positions_m[:, 0]) == 0
        turning = np.cross(oriented.positions_m[0] - centre, oriented.positions_m[1] - centre)
        assert turning[2] > 0  # counter-clockwise seen from +z
        assert_consistent_frames(oriented)
        clockwise = orient_path(ring(centre, 0.05, normal), DirectionConfig(closed_sense="cw"))
        assert np.argmin(clockwise.positions_m[:, 0]) == 0
        assert np.cross(clockwise.positions_m[0] - centre, clockwise.positions_m[1] - centre)[2] < 0


def test_a_ring_around_the_x_axis_turns_about_x_and_starts_at_its_minus_y_pose():
    centre = np.array([0.5, 0.0, 0.1])
    oriented = orient_path(ring(centre, 0.05, [-1, 0, 0]), DirectionConfig())
    assert np.argmin(oriented.positions_m[:, 1]) == 0
    assert np.cross(oriented.positions_m[0] - centre, oriented.positions_m[1] - centre)[0] > 0
    near = orient_path(ring(centre, 0.05, [1, 0, 0]), DirectionConfig(rule="start-point", start_m=(0.5, 0.0, 0.2)))
    assert np.argmax(near.positions_m[:, 2]) == 0  # the pose nearest the point above the ring


@pytest.mark.parametrize("rule", DIRECTION_RULES)
def test_applying_the_rule_twice_changes_nothing_more(rule):
    config = DirectionConfig(rule=rule, start_m=(0.1, -0.2, 0.3) if rule == "start-point" else None)
    paths = [open_path([0.5, 0.1, 0.0], [0.2, 0.3, 0.05]), open_path([0.2, 0.3, 0.05], [0.5, 0.1, 0.0]),
             ring([0.5, 0.1, 0.1], 0.05, [0.2, 0.1, 1.0]), ring([0.4, 0.0, 0.1], 0.04, [1.0, 0.2, 0.1])]
    once = orient_paths(paths, config)
    twice = orient_paths(once, config)
    for a, b in zip(once, twice):
        np.testing.assert_array_equal(a.positions_m, b.positions_m)
        np.testing.assert_array_equal(a.rotations, b.rotations)


def test_half_a_micrometre_of_noise_never_turns_a_seam_round():
    """The rule's decisions have a 10 degree margin: a seam along y (the v_butt sample's case,
    7 degrees off) and a ring keep their direction and start under any 0.5 um perturbation."""
    rng = np.random.default_rng(0)
    seam = open_path([0.011, -0.09, 0.006], [-0.012, 0.09, 0.006])
    loop = ring([0.5, 0.0, 0.1], 0.05, [0, 0, 1])
    reference = [orient_path(path, DirectionConfig()) for path in (seam, loop)]
    for _ in range(50):
        for path, expected in zip((seam, loop), reference):
            noisy = WeldPath(path.seam_id, path.positions_m + rng.uniform(-5e-7, 5e-7, path.positions_m.shape),
                             path.rotations, closed=path.closed)
            np.testing.assert_allclose(orient_path(noisy, DirectionConfig()).positions_m, expected.positions_m,
                                       atol=1e-6)
