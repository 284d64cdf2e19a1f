"""Pose files and small numeric vectors given on the command line.

One JSON format for every pose (a `--camera-pose` file, a `NAME.pose.json` sidecar, a frame
of a `--frames` manifest): an object with exactly one of
- `"T_base_camera"`: 4x4 row-major transform, camera-frame points -> base frame (metres);
- `"flange_pose"`: [x, y, z, rx, ry, rz], the UR pose vector of tool0 (the flange) in the
  base frame (metres, rotation vector in radians), combined with a hand-eye file;
- `"joints_rad"`: [q1, ..., q6], UR5 joint angles (radians) at capture, combined with a
  hand-eye file (flange pose by forward kinematics).
Other keys are ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.io.files import read_json

ROTATION_TOLERANCE = 1e-6
POSE_KEYS = ("T_base_camera", "flange_pose", "joints_rad")
POSE_KEYS_TEXT = '"T_base_camera" (4x4), "flange_pose" (x,y,z,rx,ry,rz) or "joints_rad" (6 angles)'


@dataclass(frozen=True, eq=False)
class FramePose:
    """Where the camera was for one frame: exactly one field is set.

    T_base_camera: (4, 4) camera -> base; flange_pose: (4, 4) flange (tool0) -> base;
    joints_rad: (6,) joint angles. source: the file (or option) it came from, for messages.
    """

    source: str
    T_base_camera: np.ndarray | None = None
    flange_pose: np.ndarray | None = None
    joints_rad: np.ndarray | None = None


def read_camera_pose(path: str | Path) -> np.ndarray:
    """Read `{"T_base_camera": [[...], [...], [...], [...]]}` (row-major, metres).

    Returns the (4, 4) float64 transform that maps camera-frame points to the base frame.
    Raises InputError unless it is 4x4 of finite numbers whose rotation is orthonormal
    (max |R^T R - I| <= 1e-6) with det +1 and whose last row is [0, 0, 0, 1].
    """
    path = Path(path)
    data = read_json(path, "a camera pose file")
    if not isinstance(data, dict) or "T_base_camera" not in data:
        raise InputError(f'{path}: expected a JSON object with a "T_base_camera" 4x4 matrix')
    return rigid_transform(data["T_base_camera"], f"{path}: T_base_camera")


def read_pose_file(path: str | Path) -> FramePose:
    """Read a pose file in the one pose format (module docstring); InputError naming the file."""
    data = read_json(path, "a pose file")
    return pose_from_json(data, str(path))


def pose_from_json(data, where: str) -> FramePose:
    """FramePose from a parsed pose object; `where` prefixes every error ("file: key ...")."""
    present = [key for key in POSE_KEYS if isinstance(data, dict) and key in data]
    if len(present) != 1:
        found = f" (it has {' and '.join(present)})" if present else ""
        raise InputError(f"{where}: expected a JSON object with exactly one of {POSE_KEYS_TEXT}{found}")
    (key,) = present
    if key == "T_base_camera":
        return FramePose(where, T_base_camera=rigid_transform(data[key], f"{where}: T_base_camera"))
    values = data[key]
    if not (isinstance(values, list) and len(values) == 6 and all(map(_is_number, values))
            and all(map(math.isfinite, values))):
        raise InputError(f"{where}: {key} must be a list of 6 finite numbers, got {values!r}")
    vector = np.array(values, dtype=np.float64)
    if key == "flange_pose":
        return FramePose(where, flange_pose=pose_vector_matrix(vector, f"{where}: flange_pose"))
    return FramePose(where, joints_rad=vector)


def pose_vector_matrix(vector: np.ndarray, name: str) -> np.ndarray:
    """(4, 4) transform of a UR pose vector [x, y, z, rx, ry, rz]: translation in metres,
    rotation R = exp([r]x) (axis r / |r|, angle |r| radians; UR keeps |r| <= pi, larger is
    accepted as the same rotation). `name` is used in the error for a non-finite vector."""
    from scipy.spatial.transform import Rotation

    vector = np.asarray(vector, dtype=np.float64)
    if vector.shape != (6,) or not np.isfinite(vector).all():
        raise InputError(f"{name}: expected 6 finite numbers x,y,z,rx,ry,rz")
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_rotvec(vector[3:]).as_matrix()
    matrix[:3, 3] = vector[:3]
    return matrix


def rigid_transform(rows, name: str) -> np.ndarray:
    """Validate a JSON 4x4 row-major rigid transform; `name` ("file: key") starts each error.

    Returns (4, 4) float64. InputError unless 4x4 finite numbers, last row [0, 0, 0, 1],
    rotation orthonormal (max |R^T R - I| <= 1e-6) with det +1.
    """
    if not (isinstance(rows, list) and len(rows) == 4 and all(
            isinstance(row, list) and len(row) == 4 and all(map(_is_number, row)) for row in rows)):
        raise InputError(f"{name} must be a 4x4 nested list of numbers (row-major)")
    matrix = np.array(rows, dtype=np.float64)
    if not np.isfinite(matrix).all():
        raise InputError(f"{name} has NaN or infinite entries")
    if not np.allclose(matrix[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=ROTATION_TOLERANCE):
        raise InputError(f"{name} last row must be [0, 0, 0, 1], got {matrix[3].tolist()}")
    rotation = matrix[:3, :3]
    error = float(np.abs(rotation.T @ rotation - np.eye(3)).max())
    if error > ROTATION_TOLERANCE:
        raise InputError(
            f"{name} rotation is not orthonormal "
            f"(max |R^T R - I| = {error:.2e}, tolerance {ROTATION_TOLERANCE:.0e})"
        )
    if np.linalg.det(rotation) < 0:
        raise InputError(f"{name} rotation has det -1 (a reflection, not a rotation)")
    return matrix


def _is_number(value) -> bool:
    """True for a JSON number (bool is an int subclass in Python, but not a number here)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def parse_vector(text: str, n: int, name: str) -> np.ndarray:
    """Parse `n` comma-separated finite numbers, e.g. "0.1,0.2,0.3", into an (n,) float64 array.

    name: the option the text came from (e.g. "--camera-origin"), used in the error message.
    """
    parts = text.split(",")
    try:
        values = [float(part) for part in parts]
    except ValueError:
        values = []
    if len(values) != n or not all(map(math.isfinite, values)):
        example = ",".join(f"{0.1 * (index + 1):.1f}" for index in range(n))
        raise InputError(
            f"{name}: expected {n} comma-separated numbers like {example}, got {text!r}"
        )
    return np.array(values, dtype=np.float64)
