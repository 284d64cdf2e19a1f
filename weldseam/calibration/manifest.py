"""The capture manifest of `weldseam calibrate hand-eye`: images, intrinsics, board and robot pose per capture."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from weldseam.calibration.board import Board
from weldseam.errors import InputError

DISTORTION_LENGTHS = (4, 5, 8, 12, 14)
# Pose translations beyond this are not metres on a UR arm: most likely millimetres from the teach pendant.
MAX_TRANSLATION_M = 5.0


@dataclass(frozen=True)
class Capture:
    """One manifest capture: its image file and the flange pose (4, 4) T_base_flange at that moment."""

    image: Path
    flange_pose: np.ndarray


@dataclass(frozen=True)
class Manifest:
    """A checked manifest: setup, camera matrix K (3, 3), distortion, image size, board, captures."""

    setup: str
    camera: np.ndarray
    distortion: np.ndarray
    width: int
    height: int
    board: Board
    captures: tuple[Capture, ...]


def read_manifest(path: Path) -> Manifest:
    """The manifest, every key checked; InputError naming the file and the key otherwise."""
    from weldseam.calibration.board import board_from_dict, camera_matrix
    from weldseam.calibration.handeye import SETUPS
    from weldseam.io.depth import read_intrinsics
    from weldseam.io.files import read_json

    data = read_json(path, "a capture manifest")
    if not isinstance(data, dict):
        raise InputError(f"{path}: a capture manifest must be a JSON object")
    missing = [key for key in ("setup", "intrinsics", "board", "captures") if key not in data]
    if missing:
        raise InputError(f"{path}: missing key {', '.join(missing)} (see weldseam calibrate hand-eye --help)")
    if data["setup"] not in SETUPS:
        raise InputError(f"{path}: setup must be {' or '.join(SETUPS)}, got {data['setup']!r}")
    if not isinstance(data["intrinsics"], str):
        raise InputError(f"{path}: intrinsics must be a file name (relative to the manifest)")
    intrinsics = read_intrinsics(path.parent / data["intrinsics"])
    distortion = data.get("distortion", [])
    if not (isinstance(distortion, list) and all(map(_is_number, distortion))
            and len(distortion) in (0, *DISTORTION_LENGTHS)):  # fmt: skip
        raise InputError(f"{path}: distortion must be a list of 4, 5, 8, 12 or 14 numbers (OpenCV order)")
    board = board_from_dict(data["board"], f"{path}: board")
    captures = data["captures"]
    if not isinstance(captures, list) or not all(isinstance(capture, dict) for capture in captures):
        raise InputError(f"{path}: captures must be a list of objects")
    return Manifest(
        setup=data["setup"],
        camera=camera_matrix(intrinsics),
        distortion=np.array(distortion or [0.0] * 5, dtype=np.float64),
        width=intrinsics.width,
        height=intrinsics.height,
        board=board,
        captures=tuple(_capture(path, index, capture, data.get("robot", "ur5")) for index, capture in
                       enumerate(captures, start=1)),  # fmt: skip
    )


def _capture(path: Path, number: int, entry: dict, robot: str) -> Capture:
    """One capture entry: the image path (relative to the manifest) and T_base_flange from the pose or joints."""
    from weldseam.robot.kinematics import ROBOTS, forward
    from weldseam.robot.motion import pose_matrices

    where = f"{path}: captures[{number - 1}]"
    if not isinstance(entry.get("image"), str):
        raise InputError(f'{where}: missing key "image" (the image file name)')
    if ("flange_pose" in entry) == ("joints_rad" in entry):
        raise InputError(f'{where}: give exactly one of "flange_pose" [x, y, z, rx, ry, rz] or "joints_rad"')
    key = "flange_pose" if "flange_pose" in entry else "joints_rad"
    values = entry[key]
    if not (isinstance(values, list) and len(values) == 6 and all(map(_is_number, values))):
        raise InputError(f"{where}: {key} must be a list of 6 finite numbers")
    values = np.array(values, dtype=np.float64)
    if key == "flange_pose":
        if np.abs(values[:3]).max() > MAX_TRANSLATION_M:
            raise InputError(f"{where}: flange_pose {values[:3].tolist()} looks like millimetres; UR pose vectors "
                             "are in metres")  # fmt: skip
        flange_pose = pose_matrices(values)
    else:
        if robot not in ROBOTS:
            raise InputError(f"{path}: robot must be one of {', '.join(ROBOTS)}, got {robot!r}")
        if np.abs(values).max() > 2 * np.pi + 1e-9:
            raise InputError(f"{where}: joints_rad beyond +-2 pi look like degrees; give radians")
        flange_pose = forward(ROBOTS[robot], values)
    return Capture(image=path.parent / entry["image"], flange_pose=flange_pose)


def _is_number(value) -> bool:
    """A finite JSON number (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def read_image(path: Path, width: int, height: int) -> np.ndarray:
    """A grey (H, W) uint8 image of the size the intrinsics say; InputError naming the file otherwise."""
    from weldseam.calibration.board import require_opencv
    from weldseam.calibration.opencv_output import opencv_messages
    from weldseam.io.files import read_input

    cv2 = require_opencv()
    data = read_input(path, "an image")
    with opencv_messages():  # "PNG input buffer is incomplete": our one line below says it
        image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise InputError(f"{path}: not a readable image (PNG, JPEG, BMP, TIFF)")
    if image.shape != (height, width):
        raise InputError(
            f"{path}: image is {image.shape[1]}x{image.shape[0]} but the intrinsics say {width}x{height}"
        )
    return image
