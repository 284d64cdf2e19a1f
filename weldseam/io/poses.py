"""Pose files and small numeric vectors given on the command line.

One JSON format for every pose (a `--camera-pose` file, a `NAME.pose.json` sidecar, a frame
of a `--frames` manifest): an object with exactly one of
- `"T_base_camera"`: 4x4 row-major transform, camera-frame points -> base frame (metres);
- `"flange_pose"`: [x, y, z, rx, ry, rz], the UR pose vector of tool0 (the flange) in the
  base frame (metres, rotation vector in radians), combined with a hand-eye file;
- `"joints_rad"`: [q1, ..., q6], joint angles (radians) at capture, combined with a
  hand-eye file (flange pose by forward kinematics of `"robot"`: "ur5" (the default),
  "ur5e" or "ur10").
Any other key is refused: a misspelt one would otherwise be silently ignored.

A 4x4 transform's rotation must be orthonormal within ROTATION_TOLERANCE (1e-4, so a matrix
written with 6 decimals is fine); it is then replaced by the nearest rotation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.io.files import read_json

# One tolerance for every 4x4 transform read (pose files, hand-eye files, manifests): rounding
# to 6 decimals leaves up to ~2e-6; a real error (a wrong or hand-typed matrix) is far beyond 1e-4.
ROTATION_TOLERANCE = 1e-4
# Below this the matrix is kept bit for bit (as weldseam writes it, 9 decimals or exact), so a
# recorded pose read back gives the same points.
ORTHONORMAL_AS_GIVEN = 1e-8
POSE_KEYS = ("T_base_camera", "flange_pose", "joints_rad")
POSE_KEYS_TEXT = '"T_base_camera" (4x4), "flange_pose" (x,y,z,rx,ry,rz) or "joints_rad" (6 angles)'
ROBOT_NAMES = ("ur5", "ur5e", "ur10")  # the models of weldseam.robot.kinematics.ROBOTS
DEFAULT_ROBOT = "ur5"


@dataclass(frozen=True, eq=False)
class FramePose:
    """Where the camera was for one frame: exactly one field is set.

    T_base_camera: (4, 4) camera -> base; flange_pose: (4, 4) flange (tool0) -> base;
    joints_rad: (6,) joint angles. robot: the model the joint angles are of (ROBOT_NAMES),
    None when not said. source: the file (or option) it came from, for messages.
    """

    source: str
    T_base_camera: np.ndarray | None = None
    flange_pose: np.ndarray | None = None
    joints_rad: np.ndarray | None = None
    robot: str | None = None


def read_camera_pose(path: str | Path) -> np.ndarray:
    """Read `{"T_base_camera": [[...], [...], [...], [...]]}` (row-major, metres).

    Returns the (4, 4) float64 transform that maps camera-frame points to the base frame.
    Raises InputError unless it is a valid rigid transform (see `rigid_transform`).
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


def pose_from_json(data, where: str, other_keys: tuple[str, ...] = ()) -> FramePose:
    """FramePose from a parsed pose object; `where` prefixes every error ("file: key ...").
    `other_keys` are keys the caller reads itself (a manifest frame's "scan"); any key that is
    neither one of those nor a pose key nor "robot" is refused."""
    present = [key for key in POSE_KEYS if isinstance(data, dict) and key in data]
    if len(present) != 1:
        found = f" (it has {' and '.join(present)})" if present else ""
        raise InputError(f"{where}: expected a JSON object with exactly one of {POSE_KEYS_TEXT}{found}")
    unknown = sorted(set(data) - {*POSE_KEYS, "robot", *other_keys})
    if unknown:
        allowed = ", ".join(f'"{key}"' for key in (*POSE_KEYS, "robot", *other_keys))
        raise InputError(f'{where}: unknown key "{unknown[0]}" (allowed: {allowed})')
    robot = data.get("robot")
    if robot is not None and robot not in ROBOT_NAMES:
        raise InputError(f"{where}: robot must be one of {', '.join(ROBOT_NAMES)}, got {robot!r}")
    (key,) = present
    if key == "T_base_camera":
        return FramePose(where, T_base_camera=rigid_transform(data[key], f"{where}: T_base_camera"), robot=robot)
    values = data[key]
    if not (isinstance(values, list) and len(values) == 6 and all(map(_is_number, values))
            and all(map(math.isfinite, values))):
        raise InputError(f"{where}: {key} must be a list of 6 finite numbers, got {values!r}")
    vector = np.array(values, dtype=np.float64)
    if key == "flange_pose":
        return FramePose(where, flange_pose=pose_vector_matrix(vector, f"{where}: flange_pose"), robot=robot)
    return FramePose(where, joints_rad=vector, robot=robot)


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

    Returns (4, 4) float64. InputError unless 4x4 finite numbers, last row [0, 0, 0, 1]
    (within ROTATION_TOLERANCE), rotation orthonormal (max |R^T R - I| <= ROTATION_TOLERANCE)
    with det +1. A rotation off by more than ORTHONORMAL_AS_GIVEN (a matrix rounded to 6
    decimals) is replaced by the nearest rotation, R = U V^T of the SVD R = U S V^T.
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
    matrix[3] = [0.0, 0.0, 0.0, 1.0]
    if error > ORTHONORMAL_AS_GIVEN:
        left, _, right = np.linalg.svd(rotation)
        matrix[:3, :3] = left @ right
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
