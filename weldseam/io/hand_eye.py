"""Hand-eye files, and the camera pose of a frame from the robot state at capture time.

Format (JSON, row-major 4x4 rigid transforms in metres; other keys, e.g. residuals, ignored):
- eye-in-hand (camera on the arm): `{"setup": "eye-in-hand", "T_flange_camera": 4x4}`, maps
  camera-frame points to the UR tool0 (flange) frame;
- eye-to-hand (camera fixed over the cell): `{"setup": "eye-to-hand", "T_base_camera": 4x4}`.
Then T_base_camera = T_base_flange @ T_flange_camera (eye-in-hand), or the file's own
T_base_camera (eye-to-hand: the robot state is not needed).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from weldseam.errors import InputError
from weldseam.io.files import read_json
from weldseam.io.poses import DEFAULT_ROBOT, FramePose, rigid_transform

SETUP_KEYS = {"eye-in-hand": "T_flange_camera", "eye-to-hand": "T_base_camera"}


@dataclass(frozen=True, eq=False)
class HandEye:
    """setup: "eye-in-hand" or "eye-to-hand"; transform: (4, 4) T_flange_camera or
    T_base_camera (see the module docstring); source: the file, for messages."""

    setup: str
    transform: np.ndarray
    source: str


def read_hand_eye(path: str | Path) -> HandEye:
    """Read and validate a hand-eye file; InputError naming the file and the key."""
    data = read_json(path, "a hand-eye file")
    if not isinstance(data, dict):
        raise InputError(f'{path}: expected a JSON object with "setup" and its transform')
    setup = data.get("setup")
    if setup not in SETUP_KEYS:
        raise InputError(f'{path}: setup must be "eye-in-hand" or "eye-to-hand", got {setup!r}')
    key = SETUP_KEYS[setup]
    if key not in data:
        raise InputError(f'{path}: an {setup} file needs "{key}" (a 4x4 matrix)')
    return HandEye(setup, rigid_transform(data[key], f"{path}: {key}"), str(path))


def camera_pose(
    pose: FramePose | None, hand_eye: HandEye | None, robot: str | None = None
) -> tuple[np.ndarray | None, list[str]]:
    """T_base_camera (4, 4) of a frame, or None when neither says where the camera was, and
    notes for the user.

    pose: the frame's pose (camera pose, flange pose or joints); robot: the arm the joint
    angles are of (`plan --robot`), else the pose's own "robot", else DEFAULT_ROBOT (UR5);
    T_base_flange is its forward kinematics. A camera pose and a hand-eye file together, a
    robot state without a hand-eye file, or a --robot that contradicts the pose's "robot"
    raise InputError.
    """
    if pose is not None and pose.T_base_camera is not None:
        if hand_eye is not None:
            raise InputError(
                f"{pose.source} gives T_base_camera, so {hand_eye.source} is not used: give one or the other"
            )
        return pose.T_base_camera, []
    if hand_eye is None:
        if pose is not None:
            raise InputError(f"{pose.source}: a flange pose or joint angles need a hand-eye file (--hand-eye)")
        return None, []
    if hand_eye.setup == "eye-to-hand":
        notes = [] if pose is None else [
            f"{pose.source}: the robot state is not needed with the eye-to-hand camera of {hand_eye.source}; ignored"
        ]
        return hand_eye.transform, notes
    if pose is None:
        raise InputError(
            f"{hand_eye.source}: an eye-in-hand camera needs the robot state: --flange-pose or --joints"
        )
    if pose.flange_pose is not None:
        return pose.flange_pose @ hand_eye.transform, []
    return flange_of_joints(pose.joints_rad, joints_robot(pose, robot)) @ hand_eye.transform, []


def joints_robot(pose: FramePose, robot: str | None) -> str:
    """The robot model of a pose's joint angles: --robot, else the pose's "robot", else UR5;
    InputError when the two are given and differ."""
    if robot is not None and pose.robot is not None and robot != pose.robot:
        raise InputError(f'{pose.source}: "robot" is {pose.robot} but --robot is {robot}: give one')
    return robot or pose.robot or DEFAULT_ROBOT


def flange_of_joints(joints_rad: np.ndarray, robot: str) -> np.ndarray:
    """T_base_flange (4, 4) of joint angles (6,) rad by the forward kinematics of `robot`."""
    from weldseam.robot.kinematics import ROBOTS, forward

    if robot not in ROBOTS:
        raise InputError(f"--robot must be one of {', '.join(ROBOTS)}, got {robot!r}")
    return forward(ROBOTS[robot], joints_rad)
