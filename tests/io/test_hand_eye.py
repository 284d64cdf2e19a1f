"""weldseam.io.hand_eye: the hand-eye file and the camera pose from the robot state."""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.errors import InputError
from weldseam.io.hand_eye import camera_pose, read_hand_eye
from weldseam.io.poses import FramePose, pose_vector_matrix


def transform(euler_deg, xyz):
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", euler_deg, degrees=True).as_matrix()
    matrix[:3, 3] = xyz
    return matrix


def write(tmp_path, data):
    path = tmp_path / "H.json"
    path.write_text(json.dumps(data))
    return path


def test_eye_in_hand_composes_flange_and_hand_eye(tmp_path):
    hand = transform([1, 2, 3], [0.03, -0.05, 0.06])
    path = write(tmp_path, {"setup": "eye-in-hand", "T_flange_camera": hand.tolist(), "residuals": [1]})
    calibration = read_hand_eye(path)
    flange = pose_vector_matrix(np.array([0.4, -0.1, 0.5, 0.0, np.pi, 0.0]), "x")
    pose, notes = camera_pose(FramePose("f", flange_pose=flange), calibration)
    np.testing.assert_allclose(pose, flange @ hand, atol=1e-12)
    assert notes == []


def test_eye_to_hand_needs_no_robot_state_and_says_so(tmp_path):
    fixed = transform([170, 0, 10], [0.5, 0.0, 0.8])
    calibration = read_hand_eye(write(tmp_path, {"setup": "eye-to-hand", "T_base_camera": fixed.tolist()}))
    np.testing.assert_array_equal(camera_pose(None, calibration)[0], fixed)
    pose, notes = camera_pose(FramePose("--joints", joints_rad=np.zeros(6)), calibration)
    np.testing.assert_array_equal(pose, fixed)
    assert len(notes) == 1 and "not needed" in notes[0]


@pytest.mark.parametrize("data, problem", [
    ({"setup": "eye-on-hand", "T_flange_camera": np.eye(4).tolist()}, "setup must be"),
    ({"setup": "eye-in-hand", "T_base_camera": np.eye(4).tolist()}, 'needs "T_flange_camera"'),
    ({"setup": "eye-in-hand", "T_flange_camera": (2 * np.eye(4)).tolist()}, "T_flange_camera last row"),
    ({"setup": "eye-in-hand", "T_flange_camera": np.diag([1, 1, -1, 1]).tolist()},
     "T_flange_camera rotation has det -1"),
    ({"setup": "eye-to-hand", "T_base_camera": np.eye(4)[:3].tolist()}, "T_base_camera must be a 4x4"),
    ([1, 2], "expected a JSON object"),
])
def test_bad_files_name_the_file_and_the_key(tmp_path, data, problem):
    path = write(tmp_path, data)
    with pytest.raises(InputError) as info:
        read_hand_eye(path)
    assert str(info.value).startswith(f"{path}: ") and problem in str(info.value)


def test_robot_state_without_hand_eye_and_camera_pose_with_it_are_refused(tmp_path):
    with pytest.raises(InputError, match="need a hand-eye file"):
        camera_pose(FramePose("--joints", joints_rad=np.zeros(6)), None)
    calibration = read_hand_eye(write(tmp_path, {"setup": "eye-in-hand", "T_flange_camera": np.eye(4).tolist()}))
    with pytest.raises(InputError, match="give one or the other"):
        camera_pose(FramePose("pose.json", T_base_camera=np.eye(4)), calibration)
    with pytest.raises(InputError, match="needs the robot state"):
        camera_pose(None, calibration)


def test_the_one_pose_format_reads_each_kind(tmp_path):
    from weldseam.io.poses import read_pose_file

    camera = transform([170, 0, 10], [0.5, 0.0, 0.8])
    kinds = {"T_base_camera": camera.tolist(), "flange_pose": [0.4, -0.1, 0.5, 0.0, np.pi, 0.0],
             "joints_rad": [0.0, -1.5, 1.5, -1.5, -1.5, 0.0]}
    for key, value in kinds.items():
        path = tmp_path / f"{key}.json"
        path.write_text(json.dumps({key: value}))
        pose = read_pose_file(path)
        assert pose.source == str(path)
        if key == "T_base_camera":
            np.testing.assert_array_equal(pose.T_base_camera, camera)
        elif key == "flange_pose":  # rotation vector (0, pi, 0): half a turn about y
            np.testing.assert_allclose(pose.flange_pose[:3, :3], np.diag([-1.0, 1.0, -1.0]), atol=1e-12)
            np.testing.assert_array_equal(pose.flange_pose[:3, 3], [0.4, -0.1, 0.5])
        else:
            np.testing.assert_array_equal(pose.joints_rad, value)


@pytest.mark.parametrize("data, problem", [
    ({"flange_pose": [0.1, 0.2, 0.3, 0, 0]}, "flange_pose must be a list of 6 finite numbers"),
    ({"joints_rad": [0, 0, 0, 0, 0, "1"]}, "joints_rad must be a list of 6 finite numbers"),
    ({"joints_rad": [0] * 6, "flange_pose": [0] * 6}, "exactly one of"),
    ({"T_camera_base": np.eye(4).tolist()}, "exactly one of"),
])
def test_bad_pose_files_name_the_file_and_the_key(tmp_path, data, problem):
    from weldseam.io.poses import read_pose_file

    path = tmp_path / "pose.json"
    path.write_text(json.dumps(data))
    with pytest.raises(InputError) as info:
        read_pose_file(path)
    assert str(info.value).startswith(f"{path}: ") and problem in str(info.value)


def test_a_hand_eye_file_rounded_to_6_decimals_is_accepted_like_a_pose_file(tmp_path):
    from weldseam.io.poses import read_camera_pose

    exact = read_camera_pose(Path(__file__).resolve().parents[2] / "samples" / "v_butt.pose.json")
    rounded = np.round(exact, 6).tolist()  # |R^T R - I| = 1.05e-6
    calibration = read_hand_eye(write(tmp_path, {"setup": "eye-in-hand", "T_flange_camera": rounded}))
    pose_path = tmp_path / "pose.json"
    pose_path.write_text(json.dumps({"T_base_camera": rounded}))
    np.testing.assert_array_equal(calibration.transform, read_camera_pose(pose_path))
    np.testing.assert_allclose(calibration.transform, exact, atol=2e-6)
    off = np.round(exact, 6)
    off[:3, :3] *= 1.001
    with pytest.raises(InputError, match="rotation is not orthonormal"):
        read_hand_eye(write(tmp_path, {"setup": "eye-in-hand", "T_flange_camera": off.tolist()}))


def test_joint_angles_use_the_robot_the_pose_file_names(tmp_path):
    from weldseam.io.poses import read_pose_file
    from weldseam.robot.kinematics import ROBOTS, forward

    hand = transform([1, 2, 3], [0.03, -0.05, 0.06])
    calibration = read_hand_eye(write(tmp_path, {"setup": "eye-in-hand", "T_flange_camera": hand.tolist()}))
    joints = [0.3, -1.2, 1.4, -1.7, -1.5, 0.2]
    for robot in ("ur5", "ur5e", "ur10"):
        path = tmp_path / f"{robot}.pose.json"
        path.write_text(json.dumps({"joints_rad": joints, "robot": robot}))
        pose, _ = camera_pose(read_pose_file(path), calibration)
        np.testing.assert_allclose(pose, forward(ROBOTS[robot], np.array(joints)) @ hand, atol=1e-12)
        np.testing.assert_allclose(camera_pose(read_pose_file(path), calibration, robot)[0], pose, atol=0)
    unnamed = tmp_path / "pose.json"
    unnamed.write_text(json.dumps({"joints_rad": joints}))
    ur10, _ = camera_pose(read_pose_file(unnamed), calibration, "ur10")  # plan --robot ur10
    np.testing.assert_allclose(ur10, forward(ROBOTS["ur10"], np.array(joints)) @ hand, atol=1e-12)
    ur5, _ = camera_pose(read_pose_file(unnamed), calibration)  # the default
    np.testing.assert_allclose(ur5, forward(ROBOTS["ur5"], np.array(joints)) @ hand, atol=1e-12)
    assert np.abs(ur10[:3, 3] - ur5[:3, 3]).max() > 0.05  # the models differ: the choice matters
    with pytest.raises(InputError) as info:
        camera_pose(read_pose_file(tmp_path / "ur5e.pose.json"), calibration, "ur10")
    assert str(info.value) == f'{tmp_path / "ur5e.pose.json"}: "robot" is ur5e but --robot is ur10: give one'


def test_the_robot_names_are_the_kinematic_models():
    from weldseam.io.poses import ROBOT_NAMES
    from weldseam.robot.kinematics import ROBOTS

    assert set(ROBOT_NAMES) == set(ROBOTS)


@pytest.mark.parametrize("data, problem", [
    ({"joints_rad": [0] * 6, "robot": "ur3"}, "robot must be one of ur5, ur5e, ur10, got 'ur3'"),
    ({"joints_rad": [0] * 6, "robto": "ur10"}, 'unknown key "robto" (allowed: "T_base_camera", "flange_pose", '
                                               '"joints_rad", "robot")'),
    ({"T_base_camera": np.eye(4).tolist(), "comment": "x"}, 'unknown key "comment" (allowed: "T_base_camera", '
                                                          '"flange_pose", "joints_rad", "robot")'),
])
def test_unknown_keys_and_robots_are_refused_naming_the_file(tmp_path, data, problem):
    from weldseam.io.poses import read_pose_file

    path = tmp_path / "pose.json"
    path.write_text(json.dumps(data))
    with pytest.raises(InputError) as info:
        read_pose_file(path)
    assert str(info.value) == f"{path}: {problem}"
