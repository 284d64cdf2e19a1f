"""weldseam.io.placement: which source places a scan (option, run record, file beside it), and
the record that lets a rerun place it again bit for bit."""

import json

import numpy as np
import pytest

from tests.conftest import v_groove_cloud
from weldseam.errors import InputError
from weldseam.io.placement import PlacementOptions, place_scans, read_recorded, with_placement
from weldseam.io.paths import format_path_json
from weldseam.types import RunResult


def looking_down(height_m: float, shift_m=(0.0, 0.0)) -> np.ndarray:
    """T_base_camera of a camera `height_m` above the origin looking straight down."""
    matrix = np.diag([1.0, -1.0, -1.0, 1.0])
    matrix[:3, 3] = [*shift_m, height_m]
    return matrix


@pytest.fixture
def scan(tmp_path):
    path = tmp_path / "part.npy"
    np.save(path, v_groove_cloud(np.random.default_rng(5), length_m=0.1))
    return path


def write_pose(path, matrix):
    path.write_text(json.dumps({"T_base_camera": matrix.tolist()}))
    return path


def recorded_run(tmp_path, placed) -> str:
    """A path JSON recording `placed`, as plan writes it."""
    result = with_placement(RunResult(paths=(), record={"input": {"path": "x", "sha256": placed.frames[0].sha256}}),
                            placed)
    path = tmp_path / "run.json"
    path.write_bytes(format_path_json(result))
    return path


def test_the_pose_beside_the_scan_places_it_and_is_said(scan, tmp_path):
    pose = write_pose(tmp_path / "part.pose.json", looking_down(0.5))
    placed = place_scans(PlacementOptions((str(scan),)))
    (frame,) = placed.frames
    np.testing.assert_array_equal(frame.camera_origin_m, [0.0, 0.0, 0.5])
    assert placed.messages == (f"{scan}: camera pose from {pose} (beside the scan)",)
    assert placed.placements[0]["from"] == {"pose": f"{pose} (beside the scan)"}
    assert placed.frame == "base" and placed.warnings == ()


def test_an_option_beats_the_record_which_beats_the_file_beside_the_scan(scan, tmp_path):
    explicit = write_pose(tmp_path / "explicit.json", looking_down(0.6))
    first = place_scans(PlacementOptions((str(scan),), camera_pose=str(explicit), units="m"))
    run = recorded_run(tmp_path, first)
    write_pose(tmp_path / "part.pose.json", looking_down(0.4))  # a newer file beside the scan
    rerun = place_scans(PlacementOptions((str(scan),)), read_recorded(run))
    np.testing.assert_array_equal(rerun.frames[0].camera_origin_m, [0.0, 0.0, 0.6])
    assert rerun.messages == (f"{scan}: camera pose from the record of {run}",)
    other = write_pose(tmp_path / "other.json", looking_down(0.7, (0.01, 0.0)))
    overridden = place_scans(PlacementOptions((str(scan),), camera_pose=str(other)), read_recorded(run))
    np.testing.assert_array_equal(overridden.frames[0].camera_origin_m, [0.01, 0.0, 0.7])
    without = place_scans(PlacementOptions((str(scan),)))
    np.testing.assert_array_equal(without.frames[0].camera_origin_m, [0.0, 0.0, 0.4])


def test_the_record_reads_back_exactly(scan, tmp_path):
    angle = 0.3
    tilted = looking_down(0.5)
    tilted[:3, :3] = tilted[:3, :3] @ np.array(
        [[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]])
    origin = "0.0123456789012345,-0.1,0.4987654321"
    first = place_scans(PlacementOptions((str(scan),), camera_pose=str(write_pose(tmp_path / "p.json", tilted)),
                                         camera_origin=origin, cloud_frame="base"))
    recorded = read_recorded(recorded_run(tmp_path, first))
    (placement,) = recorded.by_sha256.values()
    np.testing.assert_array_equal(placement.T_base_camera, tilted)
    np.testing.assert_array_equal(placement.camera_origin_m, [0.0123456789012345, -0.1, 0.4987654321])
    again = place_scans(PlacementOptions((str(scan),)), recorded)
    np.testing.assert_array_equal(again.frames[0].points_m, first.frames[0].points_m)
    np.testing.assert_array_equal(again.frames[0].camera_origin_m, first.frames[0].camera_origin_m)


@pytest.mark.parametrize("placement, problem", [
    ("nope", "input.placement must be an object"),
    ({"cloud_frame": "robot", "units": "m"}, "input.placement: cloud_frame must be base or camera and units m or mm"),
    ({"cloud_frame": "base", "units": "m", "T_base_camera": [[1, 0], [0, 1]]}, "input.placement.T_base_camera must "
                                                                              "be a 4x4"),
    ({"cloud_frame": "base", "units": "m", "camera_origin_m": [0, 0]}, "input.placement.camera_origin_m must be 3"),
    ({"cloud_frame": "camera", "units": "m", "intrinsics": {"width": 640}}, "input.placement.intrinsics: intrinsics "
                                                                            "lack height"),
])
def test_a_malformed_record_is_one_error_naming_the_file_and_key(tmp_path, placement, problem):
    path = tmp_path / "run.json"
    path.write_text(json.dumps({"format": "weldseam.path", "input": {"sha256": "ab", "placement": placement}}))
    with pytest.raises(InputError) as error:
        read_recorded(path)
    assert str(error.value).startswith(f"{path}: {problem}")


def test_a_toml_config_or_an_old_path_json_records_no_placement(tmp_path):
    toml = tmp_path / "cell.toml"
    toml.write_text("[normals]\nradius_m = 0.006\n")
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"format": "weldseam.path", "input": {"path": "a.ply", "sha256": "ab"}}))
    assert read_recorded(toml) is None and read_recorded(old) is None
