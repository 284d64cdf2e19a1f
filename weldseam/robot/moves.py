"""Weld paths + tool setup -> MotionPlan: the shaping modifiers applied in one fixed order."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.errors import InputError
from weldseam.robot import shaping
from weldseam.robot.motion import MotionPlan, SeamMotion, pose_matrices, pose_vectors
from weldseam.robot.work_angle import WorkAngleRule, work_angle_rule
from weldseam.types import WeldPath

TYPICAL_TCP = (0.0, 0.0, 0.2, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Shaping:
    """How paths become TCP poses. Poses are UR pose vectors (x, y, z m, rotation vector rad)."""

    base_pose: tuple = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    tcp_pose: tuple = TYPICAL_TCP
    standoff_m: float = 0.0
    work_angle_deg: float = 0.0
    travel_angle_deg: float = 0.0
    tolerance_m: float = 0.0002
    angle_tolerance_deg: float = 1.0
    approach_m: float = 0.05
    max_blend_m: float = 0.002
    payload_kg: float | None = None
    payload_cog_m: tuple | None = None
    weld_speed_m_s: float = 0.01
    move_speed_m_s: float = 0.1
    acceleration_m_s2: float = 0.5
    arc_output: int | None = None


def shaped_path(path: WeldPath, setup: Shaping) -> tuple[WeldPath, WorkAngleRule]:
    """Base frame, tilts (the work angle to its kind's side), decimation (on the seam points),
    then standoff: TCP poses as a WeldPath, with the work-angle rule it got."""
    path = shaping.to_robot_base(path, pose_matrices(np.asarray(setup.base_pose)))
    rule = work_angle_rule(path, setup.work_angle_deg)
    if rule.side is None and setup.work_angle_deg != 0.0:
        raise InputError(f"seam {path.seam_id}: its joint kind is unknown ({path.joint or 'a CSV names none'}), so a "
                         "work angle has no side; state it with --joint KIND")  # fmt: skip
    path = shaping.with_work_angle(path, rule.rotation_deg)
    path = shaping.with_travel_angle(path, setup.travel_angle_deg)
    path = shaping.decimated(path, setup.tolerance_m, setup.angle_tolerance_deg)
    return shaping.with_standoff(path, setup.standoff_m), rule


def seam_motion(path: WeldPath, setup: Shaping) -> SeamMotion:
    """One seam's approach, weld poses (K, 6), retreat and blend radii."""
    tcp, rule = shaped_path(path, setup)
    matrices = np.tile(np.eye(4), (len(tcp.positions_m), 1, 1))
    matrices[:, :3, :3] = tcp.rotations
    matrices[:, :3, 3] = tcp.positions_m
    return SeamMotion(
        seam_id=path.seam_id,
        approach_pose=pose_vectors(shaping.backed_off(matrices[0], setup.approach_m)),
        weld_poses=pose_vectors(matrices),
        retreat_pose=pose_vectors(shaping.backed_off(matrices[-1], setup.approach_m)),
        blend_radii_m=shaping.blend_radii(tcp.positions_m, setup.max_blend_m),
        work_angle=rule,
    )


def motion_plan(paths: list[WeldPath] | tuple[WeldPath, ...], setup: Shaping) -> MotionPlan:
    """All seams in file order, each with its own approach and retreat."""
    return MotionPlan(
        seams=tuple(seam_motion(path, setup) for path in paths),
        tcp_pose=np.asarray(setup.tcp_pose, dtype=np.float64),
        payload_kg=setup.payload_kg,
        payload_cog_m=setup.payload_cog_m,
        weld_speed_m_s=setup.weld_speed_m_s,
        move_speed_m_s=setup.move_speed_m_s,
        acceleration_m_s2=setup.acceleration_m_s2,
        arc_output=setup.arc_output,
    )


def estimated_time_s(plan: MotionPlan) -> float:
    """Weld length / weld speed plus approach, retreat and travel distances / move speed."""
    move_m = 0.0
    previous = None
    for seam in plan.seams:
        if previous is not None:
            move_m += float(np.linalg.norm(seam.approach_pose[:3] - previous[:3]))
        move_m += float(np.linalg.norm(seam.weld_poses[0, :3] - seam.approach_pose[:3]))
        move_m += float(np.linalg.norm(seam.retreat_pose[:3] - seam.weld_poses[-1, :3]))
        previous = seam.retreat_pose
    return plan.weld_length_m / plan.weld_speed_m_s + move_m / plan.move_speed_m_s
