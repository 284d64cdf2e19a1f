"""`weldseam plan` placed by the robot state: --flange-pose or --joints with --hand-eye give the
path of the equivalent --camera-pose; bad hand-eye files and conflicting options are one line."""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from tests.test_cli import one_error_line, weldseam
from weldseam.io.paths import read_paths
from weldseam.io.poses import read_camera_pose
from weldseam.robot.kinematics import ROBOTS, forward, inverse

SAMPLES = Path(__file__).resolve().parents[1] / "samples"
SCAN = [SAMPLES / "fillet_t.png", "--intrinsics", SAMPLES / "d415.intrinsics.json"]
T_BASE_CAMERA = read_camera_pose(SAMPLES / "fillet_t.pose.json")
T_FLANGE_CAMERA = np.eye(4)
T_FLANGE_CAMERA[:3, :3] = Rotation.from_euler("xyz", [0.5, -1.0, 90.0], degrees=True).as_matrix()
T_FLANGE_CAMERA[:3, 3] = [0.032, -0.061, 0.045]
T_BASE_FLANGE = T_BASE_CAMERA @ np.linalg.inv(T_FLANGE_CAMERA)


@pytest.fixture(scope="module")
def hand_eye(tmp_path_factory):
    path = tmp_path_factory.mktemp("he") / "H.json"
    path.write_text(json.dumps({"setup": "eye-in-hand", "T_flange_camera": T_FLANGE_CAMERA.tolist(), "rms_mm": 0.2}))
    return path


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "path.json"
    result = weldseam("plan", *SCAN, "--camera-pose", SAMPLES / "fillet_t.pose.json", "-o", out, "-q")
    assert result.returncode == 0, result.stderr
    return read_paths(out)


def same_paths(a, b):
    assert [len(p.positions_m) for p in a] == [len(p.positions_m) for p in b] and a
    for x, y in zip(a, b):
        assert np.allclose(x.positions_m, y.positions_m, atol=1e-6)
        assert np.allclose(x.rotations, y.rotations, atol=1e-6)


def test_flange_pose_and_hand_eye_give_the_camera_pose_path(reference, hand_eye, tmp_path):
    vector = np.r_[T_BASE_FLANGE[:3, 3], Rotation.from_matrix(T_BASE_FLANGE[:3, :3]).as_rotvec()]
    out = tmp_path / "path.json"
    result = weldseam("plan", *SCAN, "--flange-pose", ",".join(map(repr, vector.tolist())), "--hand-eye", hand_eye,
                      "-o", out, "-q")
    assert result.returncode == 0, result.stderr
    same_paths(read_paths(out), reference)


def test_joints_and_hand_eye_give_the_camera_pose_path(reference, hand_eye, tmp_path):
    solutions = inverse(ROBOTS["ur5"], T_BASE_FLANGE)
    assert len(solutions)
    np.testing.assert_allclose(forward(ROBOTS["ur5"], solutions[0]), T_BASE_FLANGE, atol=1e-9)
    out = tmp_path / "path.json"
    result = weldseam("plan", *SCAN, "--joints", ",".join(map(repr, solutions[0].tolist())), "--hand-eye", hand_eye,
                      "-o", out, "-q")
    assert result.returncode == 0, result.stderr
    same_paths(read_paths(out), reference)


@pytest.mark.parametrize("content, fragment", [
    ('{"setup": "eye-in-hand"}', 'needs "T_flange_camera"'),
    ('{"setup": "eye-in-hand", "T_flange_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]}',
     "T_flange_camera rotation has det -1"),
    ('{"setup": "hand", "T_flange_camera": []}', "setup must be"),
    ("{oops", "not valid JSON"),
])
def test_bad_hand_eye_file_is_one_line_naming_it(tmp_path, content, fragment):
    path = tmp_path / "bad.json"
    path.write_text(content)
    result = weldseam("plan", *SCAN, "--joints", "0,-1.5,1.5,-1.5,-1.5,0", "--hand-eye", path,
                      "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, str(path), fragment)


@pytest.mark.parametrize("options, fragment", [
    (["--camera-pose", SAMPLES / "fillet_t.pose.json", "--flange-pose", "0.1,0.2,0.3,0,0,0"],
     "--camera-pose and --flange-pose"),
    (["--flange-pose", "0.1,0.2,0.3,0,0,0", "--joints", "0,0,0,0,0,0"], "--flange-pose and --joints"),
    (["--joints", "0,0,0,0,0,0"], "--joints: a flange pose or joint angles need a hand-eye file"),
    (["--flange-pose", "0.1,0.2,0.3"], "--flange-pose: expected 6 comma-separated numbers"),
    (["--camera-pose", SAMPLES / "fillet_t.pose.json", "--hand-eye", "HAND"], "give one or the other"),
    # the T_base_camera beside the sample scan is its pose, so the hand-eye file is one too many
    (["--hand-eye", "HAND"], f"{SAMPLES / 'fillet_t.pose.json'} gives T_base_camera, so"),
    (["--joints", "0,0,0,0,0,0", "--hand-eye", "HAND", "--robot", "ur3"], "--robot must be one of ur5, ur5e, ur10"),
])
def test_conflicting_or_incomplete_options_are_one_line(hand_eye, tmp_path, options, fragment):
    options = [hand_eye if option == "HAND" else option for option in options]
    result = weldseam("plan", *SCAN, *options, "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, fragment)


def test_an_eye_in_hand_camera_without_a_robot_state_is_refused(hand_eye, tmp_path):
    lone = tmp_path / "lone.png"  # no pose file beside it
    lone.write_bytes((SAMPLES / "fillet_t.png").read_bytes())
    result = weldseam("plan", lone, *SCAN[1:], "--hand-eye", hand_eye, "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, "an eye-in-hand camera needs the robot state")


def test_eye_to_hand_needs_no_robot_state_and_says_so(reference, tmp_path):
    path = tmp_path / "fixed.json"
    path.write_text(json.dumps({"setup": "eye-to-hand", "T_base_camera": T_BASE_CAMERA.tolist()}))
    out = tmp_path / "path.json"
    result = weldseam("plan", *SCAN, "--hand-eye", path, "--joints", "0,0,0,0,0,0", "-o", out)
    assert result.returncode == 0, result.stderr
    assert "robot state is not needed" in result.stderr.decode()
    same_paths(read_paths(out), reference)


def test_several_frames_refuse_a_single_pose_option(tmp_path):
    result = weldseam("plan", SAMPLES / "fillet_t.png", SAMPLES / "v_butt.ply", "--camera-pose",
                      SAMPLES / "fillet_t.pose.json", "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, "--camera-pose applies to a single scan")


def test_a_bad_frame_in_a_manifest_is_one_line_naming_the_file_and_key(tmp_path):
    manifest = tmp_path / "frames.json"
    manifest.write_text(json.dumps({"frames": [
        {"scan": str(SAMPLES / "fillet_t.png"), "pose": str(SAMPLES / "fillet_t.pose.json")},
        {"scan": str(SAMPLES / "fillet_t.png"), "flange_pose": [0.1, 0.2, 0.3, 0.0, 0.0]},
    ]}))
    result = weldseam("plan", "--frames", manifest, "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, f"{manifest}: frames[1]: flange_pose must be a list of 6 finite numbers")


def test_a_frame_without_a_pose_is_refused(tmp_path):
    scans = []
    for name in ("a", "b"):
        (tmp_path / f"{name}.png").write_bytes((SAMPLES / "fillet_t.png").read_bytes())
        scans.append(tmp_path / f"{name}.png")
    (tmp_path / "a.pose.json").write_text((SAMPLES / "fillet_t.pose.json").read_text())
    result = weldseam("plan", *scans, "--intrinsics", SAMPLES / "d415.intrinsics.json", "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, f"{scans[1]}: no pose: give {tmp_path / 'b.pose.json'}")


def test_a_depth_image_without_a_pose_is_recorded_in_the_camera_frame_with_its_warning(tmp_path):
    lone = tmp_path / "lone.png"
    lone.write_bytes((SAMPLES / "fillet_t.png").read_bytes())
    out = tmp_path / "path.json"
    result = weldseam("plan", lone, *SCAN[1:], "-o", out)
    assert result.returncode == 0, result.stderr
    document = json.loads(out.read_text())
    warning = f"{lone}: no camera pose: the scan and the path are in the camera frame, not the robot base"
    assert document["frame"] == "camera"
    assert document["warnings"] == [warning]
    assert f"Warning: {warning}" in result.stderr.decode()
    assert document["input"]["placement"]["T_base_camera"] is None
    # The path is where the camera saw the seam: the base-frame path mapped into the camera frame.
    placed = weldseam("plan", lone, *SCAN[1:], "--camera-pose", SAMPLES / "fillet_t.pose.json", "-o",
                      tmp_path / "base.json", "-q")
    assert placed.returncode == 0 and json.loads((tmp_path / "base.json").read_text())["frame"] == "base"
    in_camera = read_paths(out)[0].positions_m
    in_base = read_paths(tmp_path / "base.json")[0].positions_m
    mapped = in_base @ T_BASE_CAMERA[:3, :3] - T_BASE_CAMERA[:3, 3] @ T_BASE_CAMERA[:3, :3]  # R^T (p - t)
    # Point for point within 2 mm of each other: the two plans space their poses differently
    # along the seam (a median of the poses moves by a spacing when one lands on the other side).
    assert cKDTree(mapped).query(in_camera)[0].max() < 0.002
    assert cKDTree(in_camera).query(mapped)[0].max() < 0.002


def test_plan_uses_the_pose_file_beside_the_scan_says_so_and_records_it(reference, tmp_path):
    scan = tmp_path / "part.png"
    scan.write_bytes((SAMPLES / "fillet_t.png").read_bytes())
    (tmp_path / "part.pose.json").write_text((SAMPLES / "fillet_t.pose.json").read_text())
    out = tmp_path / "path.json"
    result = weldseam("plan", scan, *SCAN[1:], "-o", out)
    assert result.returncode == 0, result.stderr
    assert f"{scan}: camera pose from {tmp_path / 'part.pose.json'} (beside the scan)" in result.stderr.decode()
    document = json.loads(out.read_text())
    assert document["frame"] == "base" and document["warnings"] == []
    placement = document["input"]["placement"]
    assert placement["from"]["pose"] == f"{tmp_path / 'part.pose.json'} (beside the scan)"
    np.testing.assert_array_equal(placement["T_base_camera"], T_BASE_CAMERA)
    same_paths(read_paths(out), reference)
    (tmp_path / "part.pose.json").rename(tmp_path / "pose.json")  # the folder's pose.json, as batch reads it
    again = weldseam("plan", scan, *SCAN[1:], "-o", tmp_path / "again.json", "-q")
    assert again.returncode == 0, again.stderr
    same_paths(read_paths(tmp_path / "again.json"), reference)


def test_every_warning_goes_into_the_record(reference, tmp_path):
    path = tmp_path / "fixed.json"
    path.write_text(json.dumps({"setup": "eye-to-hand", "T_base_camera": T_BASE_CAMERA.tolist()}))
    out = tmp_path / "path.json"
    result = weldseam("plan", *SCAN, "--hand-eye", path, "--joints", "0,0,0,0,0,0", "-o", out)
    assert result.returncode == 0, result.stderr
    warnings = json.loads(out.read_text())["warnings"]
    assert len(warnings) == 1 and "robot state is not needed" in warnings[0]
    assert f"Warning: {warnings[0]}" in result.stderr.decode()


def test_plan_robot_chooses_the_kinematics_of_the_joint_angles(reference, hand_eye, tmp_path):
    solutions = inverse(ROBOTS["ur10"], T_BASE_FLANGE)
    assert len(solutions)
    joints = ",".join(map(repr, solutions[0].tolist()))
    out = tmp_path / "path.json"
    result = weldseam("plan", *SCAN, "--joints", joints, "--robot", "ur10", "--hand-eye", hand_eye, "-o", out, "-q")
    assert result.returncode == 0, result.stderr
    same_paths(read_paths(out), reference)
    placement = json.loads(out.read_text())["input"]["placement"]
    assert placement["robot"] == "ur10"
    np.testing.assert_allclose(placement["T_base_camera"], T_BASE_CAMERA, atol=1e-9)
    as_ur5 = weldseam("plan", *SCAN, "--joints", joints, "--hand-eye", hand_eye, "-o", tmp_path / "ur5.json", "-q",
                      "--allow-empty")
    assert as_ur5.returncode == 0, as_ur5.stderr
    ur5 = json.loads((tmp_path / "ur5.json").read_text())["input"]["placement"]
    assert ur5["robot"] == "ur5"  # the default, recorded
    assert np.linalg.norm(np.array(ur5["T_base_camera"])[:3, 3] - T_BASE_CAMERA[:3, 3]) > 0.1
    pose = tmp_path / "state.json"
    pose.write_text(json.dumps({"joints_rad": solutions[0].tolist(), "robot": "ur10"}))
    from_file = weldseam("plan", *SCAN, "--camera-pose", pose, "--hand-eye", hand_eye, "-o", tmp_path / "f.json", "-q")
    assert from_file.returncode == 0, from_file.stderr
    same_paths(read_paths(tmp_path / "f.json"), reference)
    conflict = weldseam("plan", *SCAN, "--camera-pose", pose, "--robot", "ur5e", "--hand-eye", hand_eye, "-o",
                        tmp_path / "c.json")
    assert conflict.returncode == 2
    one_error_line(conflict, f'{pose}: "robot" is ur10 but --robot is ur5e: give one')


def test_a_manifest_frame_with_an_unknown_key_is_refused(tmp_path):
    manifest = tmp_path / "frames.json"
    manifest.write_text(json.dumps({"frames": [
        {"scan": str(SAMPLES / "fillet_t.png"), "pose": str(SAMPLES / "fillet_t.pose.json"), "robto": "ur10"},
        {"scan": str(SAMPLES / "fillet_t.png"), "joints_rad": [0.0] * 6, "robot": "ur10"},
    ]}))
    result = weldseam("plan", "--frames", manifest, "-o", tmp_path / "p.json")
    assert result.returncode == 2
    one_error_line(result, f'{manifest}: frames[0]: unknown key "robto"')
