"""Tests for weldseam.io.poses: camera pose JSON and comma-separated CLI vectors."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.errors import InputError
from weldseam.io.poses import parse_vector, read_camera_pose


SAMPLES = Path(__file__).resolve().parents[2] / "samples"


def pose_file(tmp_path, matrix, key="T_base_camera"):
    path = tmp_path / "camera.json"
    rows = matrix.tolist() if isinstance(matrix, np.ndarray) else matrix
    path.write_text(json.dumps({key: rows}))
    return path


def expect_error(path, problem: str) -> None:
    with pytest.raises(InputError) as info:
        read_camera_pose(path)
    assert re.fullmatch(re.escape(f"{path}: ") + problem, str(info.value)), str(info.value)


@pytest.fixture
def transform() -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", [170.0, -5.0, 30.0], degrees=True).as_matrix()
    matrix[:3, 3] = [0.4, -0.1, 0.6]
    return matrix


def test_reads_the_transform(tmp_path, transform):
    read = read_camera_pose(pose_file(tmp_path, transform))
    assert read.dtype == np.float64 and read.shape == (4, 4)
    np.testing.assert_array_equal(read, transform)


def test_integer_entries_are_fine(tmp_path):
    np.testing.assert_array_equal(read_camera_pose(pose_file(tmp_path, np.eye(4).astype(int))),
                                  np.eye(4))


def test_unreadable_files(tmp_path):
    expect_error(tmp_path / "missing.json", "no such file")
    expect_error(tmp_path, "is a directory, not a camera pose file")
    path = tmp_path / "camera.json"
    path.write_text("{not json")
    expect_error(path, r"not valid JSON \(.*\)")


@pytest.mark.parametrize("content, problem", [
    ({"T_camera_base": np.eye(4).tolist()},
     'expected a JSON object with a "T_base_camera" 4x4 matrix'),
    ([1, 2], 'expected a JSON object with a "T_base_camera" 4x4 matrix'),
    ({"T_base_camera": np.eye(4)[:3].tolist()},
     r"T_base_camera must be a 4x4 nested list of numbers \(row-major\)"),
    ({"T_base_camera": [[1, 0, 0, "0"], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
     r"T_base_camera must be a 4x4 nested list of numbers \(row-major\)"),
    ({"T_base_camera": [[True, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
     r"T_base_camera must be a 4x4 nested list of numbers \(row-major\)"),
    ({"T_base_camera": [[1, 0, 0, float("nan")], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
     "T_base_camera has NaN or infinite entries"),
    ({"T_base_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1]]},
     r"T_base_camera last row must be \[0, 0, 0, 1\], got \[0\.0, 0\.0, 0\.5, 1\.0\]"),
    ({"T_base_camera": [[1.001, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
     r"T_base_camera rotation is not orthonormal \(max \|R\^T R - I\| = 2\.00e-03, "
     r"tolerance 1e-04\)"),
    ({"T_base_camera": [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
     r"T_base_camera rotation has det -1 \(a reflection, not a rotation\)"),
])
def test_invalid_pose(tmp_path, content, problem):
    path = tmp_path / "camera.json"
    path.write_text(json.dumps(content))
    expect_error(path, problem)


def test_a_matrix_rounded_to_6_decimals_is_accepted_and_made_a_rotation(tmp_path):
    transform = read_camera_pose(SAMPLES / "v_butt.pose.json")
    rounded = np.round(transform, 6)
    assert np.abs(rounded[:3, :3].T @ rounded[:3, :3] - np.eye(3)).max() > 1e-6  # 1.05e-6: refused before
    read = read_camera_pose(pose_file(tmp_path, rounded))
    np.testing.assert_allclose(read[:3, :3].T @ read[:3, :3], np.eye(3), atol=1e-14)
    np.testing.assert_allclose(read, transform, atol=2e-6)
    np.testing.assert_array_equal(read[:3, 3], rounded[:3, 3])


def test_an_orthonormal_matrix_is_kept_bit_for_bit(tmp_path, transform):
    np.testing.assert_array_equal(read_camera_pose(pose_file(tmp_path, transform)), transform)
    nine = np.round(transform, 9)  # as weldseam writes a record
    np.testing.assert_array_equal(read_camera_pose(pose_file(tmp_path, nine)), nine)


def test_a_rotation_beyond_the_tolerance_is_refused(tmp_path, transform):
    transform[:3, :3] *= 1 + 1e-4  # |R^T R - I| = 2e-4
    expect_error(pose_file(tmp_path, transform), r"T_base_camera rotation is not orthonormal \(max \|R\^T R - I\| = "
                 r"2\.00e-04, tolerance 1e-04\)")


@pytest.mark.parametrize("text, expected", [
    ("0.1,0.2,0.3", [0.1, 0.2, 0.3]),
    (" -1, 2e-3 ,4 ", [-1.0, 0.002, 4.0]),
])
def test_parse_vector(text, expected):
    parsed = parse_vector(text, 3, "--camera-origin")
    assert parsed.dtype == np.float64
    np.testing.assert_array_equal(parsed, expected)


@pytest.mark.parametrize("text", ["0.1,0.2", "0.1,0.2,0.3,0.4", "a,b,c", "0.1;0.2;0.3", "",
                                  "0.1,nan,0.3", "0.1,,0.3"])
def test_parse_vector_errors(text):
    with pytest.raises(InputError) as info:
        parse_vector(text, 3, "--camera-origin")
    assert str(info.value) == (
        f"--camera-origin: expected 3 comma-separated numbers like 0.1,0.2,0.3, got {text!r}"
    )
