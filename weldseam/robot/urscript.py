"""The URScript program a dry run writes: the same moves `send` would stream, one movel per waypoint."""

from __future__ import annotations

import numpy as np

from weldseam.robot.motion import MotionPlan


def _pose(pose: np.ndarray) -> str:
    return "p[" + ", ".join(f"{value:.9g}" for value in pose) + "]"


def _movel(pose: np.ndarray, acceleration_m_s2: float, speed_m_s: float, blend_m: float = 0.0) -> str:
    return f"  movel({_pose(pose)}, a={acceleration_m_s2:.9g}, v={speed_m_s:.9g}, r={blend_m:.9g})"


def urscript(plan: MotionPlan) -> str:
    """URScript text: set_tcp, set_payload (only when the plan has one), then per seam approach, arc on, weld
    movels, arc off, retreat."""
    lines = ["def weldseam_program():", f"  set_tcp({_pose(plan.tcp_pose)})"]
    if plan.payload_kg is not None:
        cog = ", ".join(f"{value:.9g}" for value in plan.payload_cog_m)
        lines.append(f"  set_payload({plan.payload_kg:.9g}, [{cog}])")
    move = (plan.acceleration_m_s2, plan.move_speed_m_s)
    for seam in plan.seams:
        lines += [f"  # seam {seam.seam_id}", _movel(seam.approach_pose, *move), _movel(seam.weld_poses[0], *move)]
        if plan.arc_output is not None:
            lines.append(f"  set_standard_digital_out({plan.arc_output}, True)")
        lines += [
            _movel(pose, plan.acceleration_m_s2, plan.weld_speed_m_s, blend)
            for pose, blend in zip(seam.weld_poses[1:], seam.blend_radii_m[1:], strict=True)
        ]
        if plan.arc_output is not None:
            lines.append(f"  set_standard_digital_out({plan.arc_output}, False)")
        lines.append(_movel(seam.retreat_pose, *move))
    lines += ["end", "weldseam_program()", ""]
    return "\n".join(lines)
