"""Kinematics against the independent ur_analytic_ik package (same standard DH flange frame, no fixed
transform between its forward_kinematics and ours) and against geometry known by construction."""

from __future__ import annotations

import numpy as np
import pytest
import ur_analytic_ik

from weldseam.robot.kinematics import (
    ROBOTS,
    configuration,
    forward,
    inverse,
    nearest_solution,
    singularity_margins,
    wrap_angles,
)

SAMPLES = 1000


def random_joints(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-np.pi, np.pi, (SAMPLES, 6))


@pytest.mark.parametrize("name", ["ur5", "ur5e", "ur10"])
def test_forward_matches_ur_analytic_ik(name):
    model, oracle = ROBOTS[name], getattr(ur_analytic_ik, name)
    joints = random_joints(1)
    ours = forward(model, joints)
    theirs = np.array([oracle.forward_kinematics(*q) for q in joints])
    assert ours.shape == (SAMPLES, 4, 4)
    assert np.abs(ours[:, :3, 3] - theirs[:, :3, 3]).max() < 1e-9
    assert np.abs(ours[:, :3, :3] - theirs[:, :3, :3]).max() < 1e-9
    assert np.allclose(forward(model, joints[7]), theirs[7], atol=1e-12)


def same_joints(a: np.ndarray, b: np.ndarray, atol: float) -> bool:
    return bool(np.abs(wrap_angles(a - b)).max() < atol)


@pytest.mark.parametrize("name", ["ur5", "ur5e", "ur10"])
def test_every_inverse_solution_reproduces_the_pose_and_includes_the_start(name):
    model, oracle = ROBOTS[name], getattr(ur_analytic_ik, name)
    joints = random_joints(2)
    poses = forward(model, joints)
    margins = singularity_margins(model, joints)
    regular = (margins["wrist"] > 1e-3) & (margins["elbow"] > 1e-3) & (margins["shoulder_m"] > 1e-3)
    assert regular.sum() > 0.9 * SAMPLES
    for q, pose, is_regular in zip(joints, poses, regular):
        solutions = inverse(model, pose)
        assert 1 <= len(solutions) <= 8
        assert np.all(solutions > -np.pi) and np.all(solutions <= np.pi)
        assert np.abs(forward(model, solutions) - pose).max() < 1e-9
        if is_regular:
            assert any(same_joints(s, q, 1e-7) for s in solutions)
            # Every solution the oracle finds is one of ours.
            for theirs in oracle.inverse_kinematics(np.ascontiguousarray(pose)):
                assert any(same_joints(s, theirs, 1e-6) for s in solutions)


def test_a_pose_beyond_the_reach_has_no_solution():
    model = ROBOTS["ur5"]
    pose = np.eye(4)
    pose[:3, 3] = [1.2, 0.0, model.d_m[0]]
    assert inverse(model, pose).shape == (0, 6)
    inside_the_base_cylinder = np.eye(4)  # wrist centre closer to the base axis than d4: no shoulder solution
    inside_the_base_cylinder[:3, 3] = [0.0, 0.02, 0.4]
    assert inverse(model, inside_the_base_cylinder).shape == (0, 6)


def test_wrist_singular_pose_gives_solutions_with_a_chosen_q6():
    model = ROBOTS["ur5"]
    joints = np.array([0.3, -1.2, 1.4, -0.5, 0.0, 0.7])
    pose = forward(model, joints)
    solutions = inverse(model, pose)
    assert len(solutions) >= 1
    assert np.abs(forward(model, solutions) - pose).max() < 1e-9
    singular = solutions[np.abs(np.sin(solutions[:, 4])) < 1e-9]
    assert len(singular) >= 1 and np.all(singular[:, 5] == 0.0)
    # Given the q6 to keep, the singular solution is the one we started from.
    continuous = inverse(model, pose, wrist_singular_q6_rad=0.7)
    assert any(np.allclose(s, joints, atol=1e-7) for s in continuous)
    assert np.abs(forward(model, continuous) - pose).max() < 1e-9


def test_a_fully_stretched_arm_on_the_reach_boundary_is_still_solved():
    model = ROBOTS["ur5"]
    for joints in ([0.2, -0.7, 0.0, -1.0, 1.2, 0.3], [-2.0, -2.5, 0.0, 0.4, -0.8, 1.0]):
        pose = forward(model, np.array(joints))
        solutions = inverse(model, pose)
        assert any(same_joints(s, np.array(joints), 1e-6) for s in solutions)
        assert np.abs(forward(model, solutions) - pose).max() < 1e-9


def test_margins_are_zero_exactly_at_each_singularity():
    model = ROBOTS["ur5"]
    margins = singularity_margins(model, np.array([[0.1, -1.0, 0.0, 0.2, 0.5, 0.0], [0.1, -1.0, 1.0, 0.2, 0.0, 0.0]]))
    assert margins["elbow"][0] == pytest.approx(0.0, abs=1e-15)
    assert margins["wrist"][1] == pytest.approx(0.0, abs=1e-15)
    # Tool straight down with the wrist centre on the radius-d4 cylinder: both shoulder branches merge.
    pose = np.eye(4)
    pose[:3, :3] = np.diag([1.0, -1.0, -1.0])
    pose[:3, 3] = [0.0, model.d_m[3], 0.3 - model.d_m[5]]
    solutions = inverse(model, pose)
    assert len(solutions) >= 1
    assert np.all(singularity_margins(model, solutions)["shoulder_m"] < 1e-6)
    away = pose.copy()
    away[0, 3] = -0.2
    away_margins = singularity_margins(model, inverse(model, away))["shoulder_m"]
    assert np.allclose(away_margins, 0.2, atol=1e-9)


def test_nearest_solution_follows_a_smooth_trajectory_across_pi():
    model = ROBOTS["ur5"]
    t = np.linspace(0.0, 1.0, 200)[:, None]
    start = np.array([0.4, -1.3, 1.6, -1.9, -1.4, 2.6])
    trajectory = start + t * np.array([0.5, 0.3, -0.4, 0.6, 0.5, 1.5])  # q6 goes 2.6 -> 4.1 rad, through pi
    previous = trajectory[0]
    for joints, pose in zip(trajectory, forward(model, trajectory)):
        chosen = nearest_solution(inverse(model, pose), previous, model)
        assert np.allclose(chosen, joints, atol=1e-8)
        assert configuration(model, chosen) == configuration(model, start)
        previous = chosen
    assert previous[5] > np.pi


def test_nearest_solution_keeps_within_the_joint_limits_and_handles_none():
    model = ROBOTS["ur5"]
    chosen = nearest_solution(np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 3.0]]), np.array([0, 0, 0, 0, 0, 6.2]), model)
    assert chosen[5] == pytest.approx(3.0)  # 3 + 2 pi = 9.28 would pass the +360 deg limit
    assert nearest_solution(np.zeros((0, 6)), np.zeros(6), model) is None
