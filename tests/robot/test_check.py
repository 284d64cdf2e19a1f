"""check_motion on hand-built plans whose reachability and singularities are known by construction."""

from __future__ import annotations

import json

import numpy as np

from weldseam.robot.check import check_motion, describe, flange_poses
from weldseam.robot.kinematics import ROBOTS, configuration, forward, inverse
from weldseam.robot.motion import MotionPlan, SeamMotion, pose_matrices, pose_vectors

UR5 = ROBOTS["ur5"]
TOOL_DOWN = np.array([np.pi, 0.0, 0.0])  # rotation vector: tool z along -z of the base


def seam(positions_m: np.ndarray, rotvec: np.ndarray = TOOL_DOWN, seam_id: int = 1, lift_m: float = 0.05) -> SeamMotion:
    poses = np.column_stack([positions_m, np.tile(rotvec, (len(positions_m), 1))])
    lift = np.array([0.0, 0.0, lift_m, 0.0, 0.0, 0.0])
    return SeamMotion(seam_id, poses[0] + lift, poses, poses[-1] + lift, np.zeros(len(poses)))


def plan_of(*seams: SeamMotion, tcp_pose=(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)) -> MotionPlan:
    return MotionPlan(seams=seams, tcp_pose=np.array(tcp_pose, dtype=np.float64))


def line(start_m, end_m, step_m: float = 0.002) -> np.ndarray:
    start_m, end_m = np.asarray(start_m, dtype=np.float64), np.asarray(end_m, dtype=np.float64)
    count = round(np.linalg.norm(end_m - start_m) / step_m) + 1
    return start_m + np.linspace(0.0, 1.0, count)[:, None] * (end_m - start_m)


def test_a_straight_line_in_front_of_the_robot_passes_with_smooth_joints():
    report = check_motion(plan_of(seam(line([-0.45, -0.2, 0.2], [-0.45, 0.1, 0.2]))), UR5)
    assert report.ok and report.failures == ()
    kinds = [row.kind for row in report.rows]
    assert kinds == ["approach"] + ["weld"] * 151 + ["retreat"]
    weld = [row for row in report.rows if row.kind == "weld"]
    steps = np.array([row.joint_step_rad for row in weld[1:]])
    assert steps.max() < 0.02  # 2 mm apart at ~0.45 m from the base axis
    assert len({configuration(UR5, row.joints) for row in weld}) == 1
    # The chosen joints put the flange on the planned pose.
    for row in weld[::30]:
        assert np.allclose(forward(UR5, row.joints), pose_matrices(row.pose), atol=1e-9)


def test_a_pose_far_away_fails_as_unreachable_and_names_the_seam_and_index():
    positions = line([-0.45, -0.05, 0.2], [-0.45, 0.05, 0.2], step_m=0.01)
    positions[5] = [-1.2, 0.0, 0.2]
    report = check_motion(plan_of(seam(positions, seam_id=3)), UR5)
    assert not report.ok
    (failure,) = report.failures
    assert (failure.seam_id, failure.kind, failure.index, failure.joints) == (3, "weld", 5, None)
    distance_m = np.linalg.norm(pose_matrices(failure.pose)[:3, 3] - [0.0, 0.0, UR5.d_m[0]])
    assert describe(failure) == f"seam 3 weld 5: unreachable ({distance_m:.2f} m from the shoulder, reach 0.85 m)"


def test_a_pose_right_above_the_base_is_unreachable_inside_the_shoulder_offset():
    report = check_motion(plan_of(seam(np.array([[0.0, 0.02, 0.4]]), seam_id=2)), UR5)
    assert [describe(row) for row in report.rows] == [
        f"seam 2 {kind}: unreachable (wrist centre 0.020 m from the base axis, inside the 0.109 m shoulder offset)"
        for kind in ("approach", "weld 0", "retreat")
    ]


def test_a_path_passing_over_the_shoulder_fails_where_the_wrist_centre_meets_the_base_cylinder():
    # Tool vertical on the line y = d4: the wrist centre's distance in the arm plane from the base axis is |x|.
    positions = line([-0.301, UR5.d_m[3], 0.3], [0.299, UR5.d_m[3], 0.3])
    report = check_motion(plan_of(seam(positions)), UR5)
    flagged = {row.index for row in report.rows if any("shoulder singularity" in p for p in row.problems)}
    expected = {i for i, x in enumerate(positions[:, 0]) if abs(x) < 0.05}
    assert flagged == expected and len(expected) == 50
    assert not report.ok


def test_a_path_through_the_wrist_singularity_fails_with_the_wrist_problem():
    joints = np.array([0.3, -1.3, 1.5, -1.0, 0.0, 0.4]) + np.linspace(-0.3, 0.3, 61)[:, None] * [0, 0, 0, 0, 1, 0]
    poses = pose_vectors(forward(UR5, joints))
    motion = SeamMotion(1, poses[0], poses, poses[-1], np.zeros(len(poses)))
    report = check_motion(plan_of(motion), UR5, start_joints_rad=joints[0])
    flagged = [row for row in report.rows if any("wrist singularity" in p for p in row.problems)]
    # |sin q5| < 0.05 on exactly the samples with |q5| < asin(0.05) = 0.05002 rad: q5 = -0.05 .. 0.05.
    assert sorted(row.index for row in flagged if row.kind == "weld") == list(range(25, 36))
    flips = [row.index for row in report.rows if "configuration flip (wrist)" in row.problems]
    assert len(flips) == 1 and 29 <= flips[0] <= 31
    # The arm follows the joint path it was built from, through the singular pose too (q6 kept there).
    weld_joints = np.array([row.joints for row in report.rows if row.kind == "weld"])
    assert np.allclose(weld_joints, joints, atol=1e-7)
    assert not report.ok


def test_a_long_tcp_makes_a_borderline_pose_unreachable():
    positions = np.array([[-0.65, -0.11, 0.45]])
    assert check_motion(plan_of(seam(positions, lift_m=0.0)), UR5).ok
    long_torch = check_motion(plan_of(seam(positions, lift_m=0.0), tcp_pose=(0, 0, 0.2, 0, 0, 0)), UR5)
    assert not long_torch.ok
    assert all(row.problems[0].startswith("unreachable") for row in long_torch.rows)
    # The flange sits 0.2 m back along the torch axis, here straight up.
    flange = flange_poses(plan_of(seam(positions, lift_m=0.0), tcp_pose=(0, 0, 0.2, 0, 0, 0)))
    assert np.allclose(flange[1, :3, 3], [-0.65, -0.11, 0.65])


def test_a_base_pose_moves_the_plan_into_the_robot_frame():
    positions = line([0.45, 0.2, 0.2], [0.45, -0.1, 0.2], step_m=0.01)
    half_turn = np.array([0.0, 0.0, 0.0, 0.0, 0.0, np.pi])  # the plan's frame is the base turned 180 deg about z
    direct = check_motion(plan_of(seam(line([-0.45, -0.2, 0.2], [-0.45, 0.1, 0.2], step_m=0.01))), UR5)
    moved = check_motion(plan_of(seam(positions, rotvec=np.array([0.0, np.pi, 0.0]))), UR5, base_pose=half_turn)
    assert moved.ok
    assert np.allclose([row.joints for row in moved.rows], [row.joints for row in direct.rows], atol=1e-9)


def test_start_joints_choose_the_branch_and_the_step_limit_applies_along_the_seam():
    motion = seam(line([-0.45, -0.02, 0.2], [-0.45, 0.02, 0.2], step_m=0.01))
    report = check_motion(plan_of(motion), UR5)
    assert report.rows[0].joint_step_rad is None  # no start given: nothing to step from
    shoulder, elbow, wrist = configuration(UR5, report.rows[0].joints)
    solutions = inverse(UR5, flange_poses(plan_of(motion))[0])
    (elbow_flipped,) = [q for q in solutions if configuration(UR5, q) == (shoulder, -elbow, wrist)]
    other = check_motion(plan_of(motion), UR5, start_joints_rad=elbow_flipped)
    assert other.ok
    assert np.allclose(other.rows[0].joints, elbow_flipped) and other.rows[0].joint_step_rad == 0.0
    assert {configuration(UR5, row.joints) for row in other.rows} == {(shoulder, -elbow, wrist)}
    tight = check_motion(plan_of(motion), UR5, max_joint_step_rad=1e-4)
    assert all(any(p.startswith("joint step") for p in row.problems) for row in tight.rows if row.kind != "approach")


def test_report_to_dict_is_plain_and_deterministic():
    positions = line([-0.45, -0.02, 0.2], [-0.45, 0.02, 0.2], step_m=0.01)
    positions[2] = [-1.2, 0.0, 0.2]
    plan = plan_of(seam(positions, seam_id=7))
    first, second = check_motion(plan, UR5).to_dict(), check_motion(plan, UR5).to_dict()
    assert json.dumps(first, sort_keys=True) == json.dumps(second, sort_keys=True)
    assert first["ok"] is False and first["failures"] == 1 and first["poses"] == 7
    assert first["rows"][3]["joints_rad"] is None and first["rows"][3]["problems"][0].startswith("unreachable")
    assert isinstance(first["rows"][1]["margins"]["wrist"], float)
