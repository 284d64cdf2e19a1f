"""Camera pose files and small numeric vectors given on the command line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.io.files import read_json

ROTATION_TOLERANCE = 1e-6


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
    rows = data["T_base_camera"]
    if not (isinstance(rows, list) and len(rows) == 4 and all(
            isinstance(row, list) and len(row) == 4 and all(map(_is_number, row)) for row in rows)):
        raise InputError(f"{path}: T_base_camera must be a 4x4 nested list of numbers (row-major)")
    matrix = np.array(rows, dtype=np.float64)
    if not np.isfinite(matrix).all():
        raise InputError(f"{path}: T_base_camera has NaN or infinite entries")
    if not np.allclose(matrix[3], [0.0, 0.0, 0.0, 1.0], rtol=0.0, atol=ROTATION_TOLERANCE):
        raise InputError(
            f"{path}: T_base_camera last row must be [0, 0, 0, 1], got {matrix[3].tolist()}"
        )
    rotation = matrix[:3, :3]
    error = float(np.abs(rotation.T @ rotation - np.eye(3)).max())
    if error > ROTATION_TOLERANCE:
        raise InputError(
            f"{path}: T_base_camera rotation is not orthonormal "
            f"(max |R^T R - I| = {error:.2e}, tolerance {ROTATION_TOLERANCE:.0e})"
        )
    if np.linalg.det(rotation) < 0:
        raise InputError(
            f"{path}: T_base_camera rotation has det -1 (a reflection, not a rotation)"
        )
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
