"""`weldseam config show` and `plan --config`, run as a user would."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import v_groove_cloud
from weldseam.io.clouds import write_ply

CAMERA = "0,0.05,0.45"
SAMPLES = Path(__file__).resolve().parents[1] / "samples"


def weldseam(*args):
    return subprocess.run([sys.executable, "-m", "weldseam.cli", *map(str, args)], capture_output=True, timeout=120)


@pytest.fixture(scope="module")
def groove_ply(tmp_path_factory):
    path = tmp_path_factory.mktemp("scan") / "groove.ply"
    write_ply(path, v_groove_cloud(np.random.default_rng(3)))
    return path


def test_config_show_prints_toml_that_reads_back_unchanged(tmp_path):
    shown = weldseam("config", "show", "--set", "normals.radius_m=0.008", "--set", "output.rotation=quat")
    assert shown.returncode == 0 and shown.stderr == b""
    text = shown.stdout.decode()
    assert "[normals]\n" in text and "radius_m = 0.008\n" in text and 'rotation = "quat"' in text
    file = tmp_path / "cell.toml"
    file.write_text(text)
    again = weldseam("config", "show", "--config", file)
    assert again.returncode == 0 and again.stdout.decode() == text


def test_config_show_names_a_bad_key_in_one_line(tmp_path):
    file = tmp_path / "cell.toml"
    file.write_text("[normals]\nradius = 0.008\n")
    result = weldseam("config", "show", "--config", file)
    assert result.returncode == 2 and result.stdout == b""
    assert result.stderr.decode() == f"Error: {file}: unknown config key normals.radius\n"


def test_plan_takes_its_parameters_from_the_file_and_the_command_line_wins(groove_ply, tmp_path):
    file = tmp_path / "cell.toml"
    file.write_text('[resample]\nspacing_m = 0.004\n[output]\nformat = "json"\nrotation = "quat"\n')
    from_file = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "--config", file, "-o", "-", "-q")
    assert from_file.returncode == 0, from_file.stderr
    data = json.loads(from_file.stdout)  # output.format = "json" applies to stdout too
    assert data["params"]["resample"]["spacing_m"] == 0.004
    steps = np.diff([[p["x"], p["y"], p["z"]] for p in data["seams"][0]["poses"]], axis=0)
    assert abs(np.median(np.linalg.norm(steps, axis=1)) - 0.004) < 2e-4
    overridden = weldseam(
        "plan", groove_ply, "--camera-origin", CAMERA, "--config", file, "--spacing-mm", "3", "--format", "csv", "-q"
    )
    assert overridden.returncode == 0, overridden.stderr
    assert overridden.stdout.decode().splitlines()[0] == "seam,x,y,z,qx,qy,qz,qw"


def test_plan_with_the_config_of_its_own_output_reproduces_it(groove_ply, tmp_path):
    first = tmp_path / "first.json"
    ran = weldseam(
        "plan", groove_ply, "--camera-origin", CAMERA, "--set", "pairing.max_width_m=0.05", "-o", first, "-q"
    )
    assert ran.returncode == 0, ran.stderr
    second = tmp_path / "second.json"
    rerun = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "--config", first, "-o", second, "-q")
    assert rerun.returncode == 0, rerun.stderr
    a, b = json.loads(first.read_text()), json.loads(second.read_text())
    assert a["params"]["pairing"]["max_width_m"] == 0.05
    assert a["params"] == b["params"] and a["seams"] == b["seams"]


def _memory_cap():
    """At most 2 GB of address space, so that a regression fails fast instead of swapping."""
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))


def test_a_working_voxel_finer_than_the_fine_voxel_is_refused_before_the_scan_is_read(groove_ply, tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "weldseam.cli", "plan", str(groove_ply), "--camera-origin", CAMERA,
         "--set", "condition.working_voxel_m=0.0001", "-o", str(tmp_path / "p.json")],
        capture_output=True, timeout=120, preexec_fn=_memory_cap,
    )
    assert result.returncode == 2 and result.stdout == b""
    assert result.stderr.decode() == (
        "Error: condition.working_voxel_m 0.0001 is below condition.voxel_m 0.001: the working cloud coarsens the "
        "fine one, so its voxel must be at least as large\n"
    )
    assert not (tmp_path / "p.json").exists()
    both = weldseam("config", "show", "--set", "condition.voxel_m=0.0001", "--set", "condition.working_voxel_m=0.0001")
    assert both.returncode == 2
    assert both.stderr.decode().startswith("Error: smooth.radius_m 0.006 spans 60 working voxels")



def test_config_of_a_run_json_reproduces_the_run_byte_for_byte(tmp_path):
    """A camera-frame cloud in millimetres placed by a pose file, with a crop and a spacing: the
    rerun from the JSON alone (no placement option) gives the same CSV bytes."""
    from weldseam.geometry import transform_points
    from weldseam.io.clouds import read_cloud
    from weldseam.io.poses import read_camera_pose

    T_base_camera = read_camera_pose(SAMPLES / "v_butt.pose.json")
    cloud = tmp_path / "part.npy"
    np.save(cloud, transform_points(np.linalg.inv(T_base_camera), read_cloud(SAMPLES / "v_butt.ply")[0]) * 1000)
    pose = tmp_path / "elsewhere" / "cam.json"
    pose.parent.mkdir()
    pose.write_text((SAMPLES / "v_butt.pose.json").read_text())
    options = ["--cloud-frame", "camera", "--units", "mm", "--camera-pose", pose, "--camera-origin=-0.09,0.1,0.37",
               "--crop=-0.2,-0.2,-0.1,0.2,0.2,0.2", "--spacing-mm", "1.1", "--set", "pairing.max_width_m=0.05"]
    for name in ("run.json", "run.csv"):
        ran = weldseam("plan", cloud, *options, "-o", tmp_path / name, "-q")
        assert ran.returncode == 0, ran.stderr
    placement = json.loads((tmp_path / "run.json").read_text())["input"]["placement"]
    assert placement["cloud_frame"] == "camera" and placement["units"] == "mm"
    assert placement["T_base_camera"] == T_base_camera.tolist()  # exact, not rounded
    assert placement["camera_origin_m"] == [-0.09, 0.1, 0.37]
    pose.unlink()  # the rerun needs nothing but the scan and the record
    rerun = weldseam("plan", cloud, "--config", tmp_path / "run.json", "-o", tmp_path / "again.csv")
    assert rerun.returncode == 0, rerun.stderr
    assert f"{cloud}: camera pose from the record of {tmp_path / 'run.json'}" in rerun.stderr.decode()
    assert (tmp_path / "again.csv").read_bytes() == (tmp_path / "run.csv").read_bytes()
    again = json.loads(weldseam("plan", cloud, "--config", tmp_path / "run.json", "-o", "-", "--format", "json",
                                "-q").stdout)
    assert again["input"]["placement"]["T_base_camera"] == placement["T_base_camera"]


def test_config_of_a_run_json_reproduces_a_depth_image_placed_by_joints_and_hand_eye(tmp_path):
    from scipy.spatial.transform import Rotation

    from weldseam.io.poses import read_camera_pose
    from weldseam.robot.kinematics import ROBOTS, inverse

    scan = tmp_path / "part.png"
    scan.write_bytes((SAMPLES / "fillet_t.png").read_bytes())
    T_flange_camera = np.eye(4)
    T_flange_camera[:3, :3] = Rotation.from_euler("xyz", [0.5, -1.0, 90.0], degrees=True).as_matrix()
    T_flange_camera[:3, 3] = [0.032, -0.061, 0.045]
    hand_eye = tmp_path / "H.json"
    hand_eye.write_text(json.dumps({"setup": "eye-in-hand", "T_flange_camera": T_flange_camera.tolist()}))
    flange = read_camera_pose(SAMPLES / "fillet_t.pose.json") @ np.linalg.inv(T_flange_camera)
    joints = ",".join(map(repr, inverse(ROBOTS["ur5e"], flange)[0].tolist()))
    options = ["--intrinsics", SAMPLES / "d415.intrinsics.json", "--joints", joints, "--robot", "ur5e",
               "--hand-eye", hand_eye]
    for name in ("run.json", "run.csv"):
        assert weldseam("plan", scan, *options, "-o", tmp_path / name, "-q").returncode == 0
    hand_eye.unlink()
    rerun = weldseam("plan", scan, "--config", tmp_path / "run.json", "-o", tmp_path / "again.csv", "-q")
    assert rerun.returncode == 0, rerun.stderr
    assert (tmp_path / "again.csv").read_bytes() == (tmp_path / "run.csv").read_bytes()


def test_config_of_another_scans_run_gives_only_its_parameters(groove_ply, tmp_path):
    first = tmp_path / "first.json"
    ran = weldseam("plan", groove_ply, "--camera-origin", CAMERA, "--spacing-mm", "3", "-o", first, "-q")
    assert ran.returncode == 0, ran.stderr
    other = tmp_path / "other.npy"
    np.save(other, v_groove_cloud(np.random.default_rng(4)))
    result = weldseam("plan", other, "--config", first, "-o", tmp_path / "other.json")
    assert result.returncode == 0, result.stderr
    assert f"{other}: {first} was made from another scan: only its parameters are used" in result.stderr.decode()
    document = json.loads((tmp_path / "other.json").read_text())
    assert document["params"]["resample"]["spacing_m"] == 0.003
    assert document["input"]["placement"]["camera_origin_m"] is None
