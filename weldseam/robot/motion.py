"""What the arm is asked to do: TCP poses in the robot base frame, seam by seam.

A UR pose vector is (x, y, z, rx, ry, rz): metres and a rotation vector (axis * angle,
|angle| <= pi), the TCP frame in the robot base frame, as URScript's `p[...]`.
`shaping` builds a MotionPlan from weld paths, `check` verifies it, `send` executes it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from weldseam.geometry import rotation_vectors
from weldseam.robot.work_angle import WorkAngleRule


def pose_matrices(pose_vectors: np.ndarray) -> np.ndarray:
    """UR pose vectors (..., 6) -> homogeneous transforms (..., 4, 4)."""
    vectors = np.asarray(pose_vectors, dtype=np.float64)
    flat = vectors.reshape(-1, 6)
    matrices = np.tile(np.eye(4), (len(flat), 1, 1))
    matrices[:, :3, :3] = Rotation.from_rotvec(flat[:, 3:]).as_matrix()
    matrices[:, :3, 3] = flat[:, :3]
    return matrices.reshape(*vectors.shape[:-1], 4, 4)


def pose_vectors(matrices: np.ndarray) -> np.ndarray:
    """Homogeneous transforms (..., 4, 4) -> UR pose vectors (..., 6), rotation angle in [0, pi]."""
    matrices = np.asarray(matrices, dtype=np.float64)
    flat = matrices.reshape(-1, 4, 4)
    vectors = np.concatenate([flat[:, :3, 3], rotation_vectors(flat[:, :3, :3])], axis=1)
    return vectors.reshape(*matrices.shape[:-2], 6)


@dataclass(frozen=True)
class SeamMotion:
    """One seam: approach above its start, the weld itself, retreat above its end.

    approach_pose, retreat_pose: (6,) UR pose vectors (TCP in the robot base frame).
    weld_poses: (K, 6) UR pose vectors in travel order (a closed seam repeats its first pose last).
    blend_radii_m: (K,) blend radius per weld pose; each <= half the shorter adjacent segment,
        the first and the last 0.
    work_angle: the side its work angle turned the torch to (None: not shaped from a weld path).
    """

    seam_id: int
    approach_pose: np.ndarray
    weld_poses: np.ndarray
    retreat_pose: np.ndarray
    blend_radii_m: np.ndarray
    work_angle: WorkAngleRule | None = None

    @property
    def length_m(self) -> float:
        """Length of the weld (the approach and retreat moves excluded)."""
        return float(np.linalg.norm(np.diff(self.weld_poses[:, :3], axis=0), axis=1).sum())


@dataclass(frozen=True)
class MotionPlan:
    """Everything `send` needs, already checked-ready: no geometry is decided after this.

    tcp_pose: (6,) TCP (torch tip) relative to the flange, UR pose vector (setTcp).
    payload_kg, payload_cog_m: mass and centre of gravity (3,) m from the flange for setPayload; None leaves
        the payload configured on the robot untouched.
    weld_speed_m_s: travel speed along the weld.
    move_speed_m_s, acceleration_m_s2: for the approach, retreat and travel moves.
    arc_output: standard digital output that switches the arc, or None for a dry path.
    """

    seams: tuple[SeamMotion, ...]
    tcp_pose: np.ndarray
    payload_kg: float | None = None
    payload_cog_m: tuple | None = None
    weld_speed_m_s: float = 0.01
    move_speed_m_s: float = 0.1
    acceleration_m_s2: float = 0.5
    arc_output: int | None = None

    @property
    def weld_length_m(self) -> float:
        return sum(seam.length_m for seam in self.seams)
