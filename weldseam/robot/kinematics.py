"""Universal Robots kinematics: DH tables, forward and analytic inverse kinematics, singularity margins.

Standard (Denavit-Hartenberg) convention as published by Universal Robots: joint i turns about z_{i-1};
link i is Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i). The last frame is the tool flange (z out of the flange),
with no extra fixed transform. Inverse kinematics follows Hawkins, "Analytic Inverse Kinematics for the
Universal Robots UR-5/UR-10 Arms" (2013): up to 8 solutions, shoulder (q1) x wrist (q5) x elbow (q3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * np.pi
# acos/asin arguments this far beyond +-1 are rounding noise at the workspace boundary, not unreachable poses.
BOUNDARY_TOLERANCE = 1e-9
# Below this |sin q5| the wrist is singular: q4 and q6 turn about the same axis, q5 snaps to 0 or pi and q6 is
# chosen. acos near 1 turns rounding (1e-16) into ~1e-8 rad, so anything below 1e-7 is treated as singular.
WRIST_SINGULAR_SIN = 1e-7


@dataclass(frozen=True)
class RobotModel:
    """One arm: DH parameters (m, rad), joint limits (6, 2) rad as (min, max), nominal reach (m)."""

    name: str
    d_m: np.ndarray
    a_m: np.ndarray
    alpha_rad: np.ndarray
    joint_limits_rad: np.ndarray
    reach_m: float

    @property
    def shoulder_m(self) -> np.ndarray:
        """(3,) the shoulder point in the base frame: base axis meets the shoulder axis (0, 0, d1)."""
        return np.array([0.0, 0.0, self.d_m[0]])


def _ur_model(name: str, d1: float, a2: float, a3: float, d4: float, d5: float, d6: float, reach_m: float):
    return RobotModel(
        name=name,
        d_m=np.array([d1, 0.0, 0.0, d4, d5, d6]),
        a_m=np.array([0.0, a2, a3, 0.0, 0.0, 0.0]),
        alpha_rad=np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0]),
        joint_limits_rad=np.tile([-TWO_PI, TWO_PI], (6, 1)),
        reach_m=reach_m,
    )


# Universal Robots' published DH tables (CB3 UR5 and UR10, e-Series UR5e); every joint +-360 deg.
ROBOTS: dict[str, RobotModel] = {
    "ur5": _ur_model("ur5", 0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823, reach_m=0.85),
    "ur5e": _ur_model("ur5e", 0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996, reach_m=0.85),
    "ur10": _ur_model("ur10", 0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922, reach_m=1.3),
}


def wrap_angles(angles_rad: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angles_rad, dtype=np.float64), TWO_PI)


def _link_transforms(model: RobotModel, joints_rad: np.ndarray) -> np.ndarray:
    """(N, 6) joints -> (N, 6, 4, 4) transform of each link i, frame i-1 -> frame i."""
    q = np.asarray(joints_rad, dtype=np.float64)
    cos_q, sin_q = np.cos(q), np.sin(q)
    cos_a, sin_a = np.cos(model.alpha_rad), np.sin(model.alpha_rad)
    links = np.zeros(q.shape + (4, 4))
    links[..., 0, 0] = cos_q
    links[..., 0, 1] = -sin_q * cos_a
    links[..., 0, 2] = sin_q * sin_a
    links[..., 0, 3] = model.a_m * cos_q
    links[..., 1, 0] = sin_q
    links[..., 1, 1] = cos_q * cos_a
    links[..., 1, 2] = -cos_q * sin_a
    links[..., 1, 3] = model.a_m * sin_q
    links[..., 2, 1] = sin_a
    links[..., 2, 2] = cos_a
    links[..., 2, 3] = model.d_m
    links[..., 3, 3] = 1.0
    return links


def _link(model: RobotModel, index: int, angles_rad: np.ndarray) -> np.ndarray:
    """(M,) angles of joint `index` (0-based) -> (M, 4, 4) transforms of that link alone."""
    joints = np.zeros((len(angles_rad), 6))
    joints[:, index] = angles_rad
    return _link_transforms(model, joints)[:, index]


def frames(model: RobotModel, joints_rad: np.ndarray) -> np.ndarray:
    """(N, 6) joints -> (N, 6, 4, 4) pose of frames 1..6 in the base frame (frame 6 = flange)."""
    links = _link_transforms(model, np.atleast_2d(joints_rad))
    poses = np.empty_like(links)
    poses[:, 0] = links[:, 0]
    for i in range(1, 6):
        poses[:, i] = poses[:, i - 1] @ links[:, i]
    return poses


def forward(model: RobotModel, joints_rad: np.ndarray) -> np.ndarray:
    """Flange pose in the base frame: joints (6,) or (N, 6) rad -> (4, 4) or (N, 4, 4)."""
    joints = np.asarray(joints_rad, dtype=np.float64)
    poses = frames(model, joints.reshape(-1, 6))[:, 5]
    return poses[0] if joints.ndim == 1 else poses


def _clipped(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Clip acos/asin arguments that exceed +-1 by rounding only; also return which ones are valid."""
    valid = np.abs(values) <= 1.0 + BOUNDARY_TOLERANCE
    return np.clip(values, -1.0, 1.0), valid


def inverse(model: RobotModel, flange_pose: np.ndarray, *, wrist_singular_q6_rad: float = 0.0) -> np.ndarray:
    """All analytic solutions (k, 6), k <= 8, wrapped to (-pi, pi], for a (4, 4) flange pose; (0, 6) if none.

    q1 from the wrist centre p5 = p - d6 z (two shoulder branches), q5 from the flange position along the
    shoulder's normal (two wrist branches), q6 from the flange orientation, then q3 from the planar two-link
    arm (two elbow branches), q2 and q4. At the wrist singularity (sin q5 ~ 0) only q4 + q6 is determined:
    q6 is set to `wrist_singular_q6_rad` (pass the previous q6 to keep a trajectory continuous).
    """
    pose = np.asarray(flange_pose, dtype=np.float64)
    d4, d6 = model.d_m[3], model.d_m[5]
    a2, a3 = model.a_m[1], model.a_m[2]
    wrist_centre = pose[:3, 3] - d6 * pose[:3, 2]
    radius_m = np.hypot(wrist_centre[0], wrist_centre[1])
    if radius_m < abs(d4) * (1.0 - BOUNDARY_TOLERANCE):
        return np.zeros((0, 6))
    phi = np.arccos(np.clip(d4 / radius_m, -1.0, 1.0))
    psi = np.arctan2(wrist_centre[1], wrist_centre[0])
    q1 = np.array([psi + phi, psi - phi]) + np.pi / 2

    cos_q5, valid5 = _clipped((pose[0, 3] * np.sin(q1) - pose[1, 3] * np.cos(q1) - d4) / d6)
    q5_abs = np.arccos(cos_q5)
    q1 = np.repeat(q1, 2)
    q5 = np.stack([q5_abs, -q5_abs], axis=1).ravel()
    valid = np.repeat(valid5, 2)

    inverse_pose = np.linalg.inv(pose)
    sin_q1, cos_q1, sin_q5 = np.sin(q1), np.cos(q1), np.sin(q5)
    wrist_singular = np.abs(sin_q5) < WRIST_SINGULAR_SIN
    safe_sin_q5 = np.where(wrist_singular, 1.0, sin_q5)
    q6 = np.arctan2(
        (-inverse_pose[1, 0] * sin_q1 + inverse_pose[1, 1] * cos_q1) / safe_sin_q5,
        (inverse_pose[0, 0] * sin_q1 - inverse_pose[0, 1] * cos_q1) / safe_sin_q5,
    )
    q6 = np.where(wrist_singular, wrist_singular_q6_rad, q6)
    q5 = np.where(wrist_singular, np.pi * np.round(q5 / np.pi), q5)

    # Frame 1 -> frame 4 from the known q1, q5, q6; p13, frame 3's origin seen from frame 1, is the end of the
    # planar two-link arm (a2, a3): its length gives q3, its direction q2; the rest of the turn is q4.
    to_frame1 = np.linalg.inv(_link(model, 0, q1))
    from_frame4 = np.linalg.inv(_link(model, 4, q5) @ _link(model, 5, q6))
    frame1_to_4 = to_frame1 @ pose @ from_frame4
    p13 = (frame1_to_4 @ np.array([0.0, -d4, 0.0, 1.0]))[:, :3]
    p13_norm = np.linalg.norm(p13, axis=1)
    cos_q3, valid3 = _clipped((p13_norm**2 - a2**2 - a3**2) / (2.0 * a2 * a3))
    q3_abs = np.arccos(cos_q3)
    q1, q5, q6, p13, p13_norm, frame1_to_4 = (np.repeat(x, 2, axis=0) for x in (q1, q5, q6, p13, p13_norm, frame1_to_4))
    q3 = np.stack([q3_abs, -q3_abs], axis=1).ravel()
    valid = np.repeat(valid & valid3, 2)
    sin_arg, valid2 = _clipped(a3 * np.sin(q3) / np.where(p13_norm > 0, p13_norm, 1.0))
    q2 = -np.arctan2(p13[:, 1], -p13[:, 0]) + np.arcsin(sin_arg)
    valid &= valid2
    frame3_to_4 = np.linalg.inv(_link(model, 1, q2) @ _link(model, 2, q3)) @ frame1_to_4
    q4 = np.arctan2(frame3_to_4[:, 1, 0], frame3_to_4[:, 0, 0])

    solutions = wrap_angles(np.stack([q1, q2, q3, q4, q5, q6], axis=1)[valid])
    if len(solutions) == 0:
        return np.zeros((0, 6))
    # Coinciding branches (q3 = 0 or pi, q5 = 0 or pi) give the same joints twice: keep one of each.
    _, first = np.unique(np.round(solutions, 9), axis=0, return_index=True)
    return solutions[np.sort(first)]


def equivalent_joints(model: RobotModel, solutions: np.ndarray, reference_rad: np.ndarray) -> np.ndarray:
    """Shift each joint of (k, 6) solutions by a multiple of 2 pi, within the limits, to be nearest the reference.

    A joint with no equivalent inside its limits becomes NaN.
    """
    solutions = np.atleast_2d(np.asarray(solutions, dtype=np.float64))
    reference = np.asarray(reference_rad, dtype=np.float64)
    turns = np.round((reference - solutions) / TWO_PI)
    candidates = solutions[..., None] + TWO_PI * (turns[..., None] + np.array([-1.0, 0.0, 1.0]))
    low, high = model.joint_limits_rad[:, 0, None], model.joint_limits_rad[:, 1, None]
    inside = (candidates >= low - 1e-12) & (candidates <= high + 1e-12)
    distance = np.where(inside, np.abs(candidates - reference[:, None]), np.inf)
    best = np.argmin(distance, axis=-1)
    shifted = np.take_along_axis(candidates, best[..., None], axis=-1)[..., 0]
    return np.where(np.isfinite(np.min(distance, axis=-1)), shifted, np.nan)


def nearest_solution(
    solutions: np.ndarray, reference_rad: np.ndarray, model: RobotModel | None = None
) -> np.ndarray | None:
    """The solution (6,) nearest the reference joints (Euclidean, rad), or None when there is none.

    Each joint may be taken as any 2 pi-shifted equivalent that stays inside the model's joint limits
    (UR5 by default, +-360 deg); the returned joints are that equivalent, so a trajectory stays continuous.
    """
    model = model or ROBOTS["ur5"]
    shifted = equivalent_joints(model, solutions, reference_rad)
    shifted = shifted[~np.isnan(shifted).any(axis=1)]
    if len(shifted) == 0:
        return None
    return shifted[np.argmin(np.linalg.norm(shifted - np.asarray(reference_rad), axis=1))]


def singularity_margins(model: RobotModel, joints_rad: np.ndarray) -> dict[str, np.ndarray]:
    """Distance from each singularity for joints (6,) or (N, 6); 0 means singular.

    wrist: |sin q5|, 0 when the q4 and q6 axes line up (the wrist spins unboundedly near it).
    elbow: |sin q3|, 0 with the arm fully stretched (workspace boundary) or folded.
    shoulder_m: distance (m) of the wrist centre (where the q5 and q6 axes meet) from the base z axis,
        measured in the arm's plane, i.e. sqrt(r^2 - d4^2) with r its radial distance; 0 when the wrist
        centre is on the cylinder of radius d4 around the base axis, where the two shoulder solutions merge.
    """
    joints = np.asarray(joints_rad, dtype=np.float64)
    wrist_centre = frames(model, joints.reshape(-1, 6))[:, 4, :3, 3]
    radius_sq = wrist_centre[:, 0] ** 2 + wrist_centre[:, 1] ** 2
    margins = {
        "wrist": np.abs(np.sin(joints.reshape(-1, 6)[:, 4])),
        "elbow": np.abs(np.sin(joints.reshape(-1, 6)[:, 2])),
        "shoulder_m": np.sqrt(np.maximum(radius_sq - model.d_m[3] ** 2, 0.0)),
    }
    return {name: value[0] if joints.ndim == 1 else value for name, value in margins.items()}


def configuration(model: RobotModel, joints_rad: np.ndarray) -> tuple[int, int, int]:
    """Branch signs (shoulder, elbow, wrist) of (6,) joints, each +1 or -1.

    shoulder: side of the wrist centre along the shoulder link's x axis (the two q1 solutions);
    elbow: sign of sin q3; wrist: sign of sin q5. Joints keep one configuration along a weld.
    """
    joints = np.asarray(joints_rad, dtype=np.float64)
    wrist_centre = frames(model, joints)[0, 4, :3, 3]
    shoulder = wrist_centre[0] * np.cos(joints[0]) + wrist_centre[1] * np.sin(joints[0])
    return tuple(1 if value >= 0 else -1 for value in (shoulder, np.sin(joints[2]), np.sin(joints[4])))
