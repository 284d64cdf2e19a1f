"""Reachability check of a MotionPlan before any motion: IK per pose, joint continuity, singularities, limits.

Every pose is visited in plan order (per seam: approach, weld poses, retreat). Its flange pose is
T_base_frame @ T_frame_tcp @ inv(T_flange_tcp); of its IK solutions the one nearest the previous pose's
joints is taken (the first pose of the plan: nearest `start_joints_rad`, else nearest HOME_JOINTS_RAD).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from weldseam.robot.kinematics import RobotModel, configuration, inverse, nearest_solution, singularity_margins
from weldseam.robot.motion import MotionPlan, pose_matrices

# The usual UR home, (0, -90, 90, -90, -90, 0) deg: flange at (-0.49, -0.11, 0.43) m on a UR5, tool z down.
# The first pose of a plan takes the IK solution nearest it: the arm reaching along -x, elbow up, wrist down.
HOME_JOINTS_RAD = np.radians([0.0, -90.0, 90.0, -90.0, -90.0, 0.0])

# Between neighbouring weld waypoints (2 mm apart when resampled, up to a few cm after decimation) a
# comfortable arm turns each joint by hundredths of a radian; 0.5 rad (29 deg) in one straight moveL
# segment means the segment passes a singularity or the solution changed branch.
MAX_JOINT_STEP_RAD = 0.5
# |sin q5| = 0.05 is q5 within 2.9 deg of 0 or 180 deg: joint speeds of q4/q6 grow as 1/|sin q5|
# (20x the Cartesian rate here), beyond what a steady weld speed tolerates.
MIN_WRIST_MARGIN = 0.05
# |sin q3| = 0.05: elbow within 2.9 deg of stretched (the reach limit) or folded.
MIN_ELBOW_MARGIN = 0.05
# Wrist centre 5 cm from the shoulder singularity: q1 speed grows as 1/distance, 0.2 rad/s per 10 mm/s there.
MIN_SHOULDER_MARGIN_M = 0.05


@dataclass(frozen=True)
class PoseCheck:
    """The check of one pose of the plan.

    kind: "approach", "weld" or "retreat"; index: 0 for approach/retreat, else the weld pose index.
    pose: (6,) TCP pose as planned; joints: (6,) rad chosen, None when unreachable.
    joint_step_rad: max |joint change| from the previous reachable pose (None for the first / unreachable).
    margins: singularity margins (see kinematics.singularity_margins), empty when unreachable.
    problems: human-readable failures, empty when the pose passes.
    """

    seam_id: int
    kind: str
    index: int
    pose: np.ndarray
    joints: np.ndarray | None
    joint_step_rad: float | None
    margins: dict[str, float]
    problems: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return not self.problems

    def to_dict(self) -> dict:
        """Plain JSON-able values."""
        return {
            "seam_id": int(self.seam_id),
            "kind": self.kind,
            "index": int(self.index),
            "pose": [float(v) for v in self.pose],
            "joints_rad": None if self.joints is None else [float(v) for v in self.joints],
            "joint_step_rad": None if self.joint_step_rad is None else float(self.joint_step_rad),
            "margins": {name: float(value) for name, value in self.margins.items()},
            "problems": list(self.problems),
        }


def describe(row: PoseCheck) -> str:
    """One line for a person, e.g. 'seam 2 weld 17: unreachable (0.93 m from the shoulder, reach 0.85 m)'."""
    where = f"seam {row.seam_id} {row.kind}" + (f" {row.index}" if row.kind == "weld" else "")
    return f"{where}: " + ("ok" if row.ok else "; ".join(row.problems))


@dataclass(frozen=True)
class CheckReport:
    """Every pose's check, in plan order, with the robot and thresholds used."""

    robot: str
    rows: tuple[PoseCheck, ...]
    thresholds: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return all(row.ok for row in self.rows)

    @property
    def failures(self) -> tuple[PoseCheck, ...]:
        return tuple(row for row in self.rows if not row.ok)

    def to_dict(self) -> dict:
        """For `--json`: plain floats, rows in plan order."""
        return {
            "ok": self.ok,
            "robot": self.robot,
            "thresholds": {name: float(value) for name, value in self.thresholds.items()},
            "poses": len(self.rows),
            "failures": len(self.failures),
            "rows": [row.to_dict() for row in self.rows],
        }


def _plan_poses(plan: MotionPlan) -> list[tuple[int, str, int, np.ndarray]]:
    """(seam_id, kind, index, pose (6,)) for every pose of the plan in order."""
    poses = []
    for seam in plan.seams:
        poses.append((seam.seam_id, "approach", 0, np.asarray(seam.approach_pose, dtype=np.float64)))
        poses.extend((seam.seam_id, "weld", i, np.asarray(p, dtype=np.float64)) for i, p in enumerate(seam.weld_poses))
        poses.append((seam.seam_id, "retreat", 0, np.asarray(seam.retreat_pose, dtype=np.float64)))
    return poses


def flange_poses(plan: MotionPlan, base_pose: np.ndarray | None = None) -> np.ndarray:
    """(M, 4, 4) flange poses in the robot base for every plan pose, in order.

    base_pose: (6,) pose of the plan's frame in the robot base (None: the plan is in the robot base).
    """
    tcp_poses = pose_matrices(np.array([pose for *_, pose in _plan_poses(plan)]).reshape(-1, 6))
    base = np.eye(4) if base_pose is None else pose_matrices(np.asarray(base_pose, dtype=np.float64))
    return base @ tcp_poses @ np.linalg.inv(pose_matrices(np.asarray(plan.tcp_pose, dtype=np.float64)))


def _unreachable_reason(model: RobotModel, flange_pose: np.ndarray) -> str:
    """Why IK found nothing: wrist centre too near the base axis, beyond the reach, or the orientation."""
    shoulder_offset_m = model.d_m[3]
    wrist_centre = flange_pose[:3, 3] - model.d_m[5] * flange_pose[:3, 2]
    axis_distance_m = float(np.hypot(wrist_centre[0], wrist_centre[1]))
    if axis_distance_m < shoulder_offset_m:
        return (
            f"unreachable (wrist centre {axis_distance_m:.3f} m from the base axis, "
            f"inside the {shoulder_offset_m:.3f} m shoulder offset)"
        )
    distance_m = float(np.linalg.norm(flange_pose[:3, 3] - model.shoulder_m))
    if distance_m > model.reach_m:
        return f"unreachable ({distance_m:.2f} m from the shoulder, reach {model.reach_m:.2f} m)"
    return f"unreachable (no joint solution in this orientation, {distance_m:.2f} m from the shoulder)"


def check_motion(
    plan: MotionPlan,
    model: RobotModel,
    *,
    start_joints_rad: np.ndarray | None = None,
    max_joint_step_rad: float = MAX_JOINT_STEP_RAD,
    min_wrist_margin: float = MIN_WRIST_MARGIN,
    min_shoulder_margin_m: float = MIN_SHOULDER_MARGIN_M,
    min_elbow_margin: float = MIN_ELBOW_MARGIN,
    base_pose: np.ndarray | None = None,
) -> CheckReport:
    """Check every pose of `plan` on `model`; the report's `ok` is True only if all pass.

    Problems per pose: unreachable; outside the joint limits; a singularity margin below its threshold;
    along a seam (weld poses and the retreat, each against the pose before it) a joint step above
    `max_joint_step_rad` or a change of configuration (shoulder/elbow/wrist branch). The move onto a
    seam's approach pose (travel from the previous seam or the start) is reported but not limited.
    """
    thresholds = {
        "max_joint_step_rad": max_joint_step_rad,
        "min_wrist_margin": min_wrist_margin,
        "min_elbow_margin": min_elbow_margin,
        "min_shoulder_margin_m": min_shoulder_margin_m,
    }
    minimum = {"wrist": min_wrist_margin, "elbow": min_elbow_margin, "shoulder_m": min_shoulder_margin_m}
    previous = np.asarray(HOME_JOINTS_RAD if start_joints_rad is None else start_joints_rad, dtype=np.float64)
    has_previous = start_joints_rad is not None
    previous_seam = None
    low, high = model.joint_limits_rad[:, 0], model.joint_limits_rad[:, 1]
    rows = []
    for (seam_id, kind, index, pose), flange_pose in zip(_plan_poses(plan), flange_poses(plan, base_pose)):
        solutions = inverse(model, flange_pose, wrist_singular_q6_rad=float(previous[5]))
        if len(solutions) == 0:
            rows.append(
                PoseCheck(seam_id, kind, index, pose, None, None, {}, (_unreachable_reason(model, flange_pose),))
            )
            continue
        joints = nearest_solution(solutions, previous, model)
        problems = []
        if joints is None:
            joints = solutions[0]
            problems.append("outside the joint limits")
        elif np.any(joints < low - 1e-9) or np.any(joints > high + 1e-9):
            problems.append("outside the joint limits")
        margins = {name: float(value) for name, value in singularity_margins(model, joints).items()}
        for name, value in margins.items():
            if value < minimum[name]:
                label = name.removesuffix("_m")
                problems.append(f"near the {label} singularity ({label} margin {value:.3g} < {minimum[name]:.3g})")
        step_rad = float(np.max(np.abs(joints - previous))) if has_previous else None
        along_seam = kind != "approach" and previous_seam == seam_id
        if along_seam and step_rad is not None:
            if step_rad > max_joint_step_rad:
                problems.append(f"joint step {step_rad:.3f} rad > {max_joint_step_rad:.3f} rad")
            changed = [
                name
                for name, before, after in zip(
                    ("shoulder", "elbow", "wrist"), configuration(model, previous), configuration(model, joints)
                )
                if before != after
            ]
            if changed:
                problems.append("configuration flip (" + ", ".join(changed) + ")")
        rows.append(PoseCheck(seam_id, kind, index, pose, joints, step_rad, margins, tuple(problems)))
        previous, has_previous, previous_seam = joints, True, seam_id
    return CheckReport(robot=model.name, rows=tuple(rows), thresholds=thresholds)
