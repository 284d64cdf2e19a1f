"""Execute a checked MotionPlan with a robot client: the fixed sequence, arc safety, Ctrl-C/SIGTERM.

The client (weldseam.robot.client.UrClient or a test double) provides set_tcp, set_payload,
move_linear(pose6, speed_m_s, acceleration_m_s2), move_path(entries (K, 9), on_progress),
set_digital_output(index, on), stop() and actual_tcp_pose(); faults raise RobotFault.
No motion is ever retried.
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np

from weldseam.errors import RobotFault
from weldseam.robot.motion import MotionPlan, SeamMotion


def path_entries(seam: SeamMotion, plan: MotionPlan) -> np.ndarray:
    """(K, 9) moveL path entries: pose (6), weld speed m/s, acceleration m/s^2, blend m."""
    count = len(seam.weld_poses)
    return np.column_stack(
        [
            seam.weld_poses,
            np.full(count, plan.weld_speed_m_s),
            np.full(count, plan.acceleration_m_s2),
            seam.blend_radii_m,
        ]
    )


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """For the duration: SIGTERM raises KeyboardInterrupt in the main thread (like Ctrl-C)."""

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _arc(client, plan: MotionPlan, on: bool) -> None:
    if plan.arc_output is not None:
        client.set_digital_output(plan.arc_output, on)


def _safe_stop(client, plan: MotionPlan) -> str:
    """Stop the arm and switch the arc off, each as far as the connection still allows; say what is known."""
    try:
        client.stop()
        stopped = "arm stopped"
    except Exception:
        stopped = "stopL not confirmed"
    try:
        _arc(client, plan, False)
        arc = "arc off"
    except Exception:
        arc = "ARC OUTPUT NOT CONFIRMED OFF: check the cell"
    return f"{stopped}, {arc}"


def execute(
    plan: MotionPlan,
    client,
    *,
    on_progress: Callable[[int, int], None] | None = None,
    on_pose: Callable[[int, int, np.ndarray], None] | None = None,
) -> None:
    """Run the plan: setTcp, setPayload; per seam approach, first weld pose, arc on, one moveL path, arc off, retreat.

    on_progress(seam_index, waypoint_index) follows the controller's async progress; on_pose(seam_index,
    waypoint_index, actual_tcp_pose6) receives the measured TCP at each progress report.
    Ctrl-C (or SIGTERM) stops the arm, switches the arc off and re-raises KeyboardInterrupt. A RobotFault
    switches the arc off, stops, and is re-raised naming the seam and the waypoint.
    """
    seam_index, waypoint = -1, -1
    try:
        client.set_tcp(np.asarray(plan.tcp_pose, dtype=float))
        client.set_payload(plan.payload_kg)
        for seam_index, seam in enumerate(plan.seams):
            waypoint = -1
            client.move_linear(seam.approach_pose, plan.move_speed_m_s, plan.acceleration_m_s2)
            client.move_linear(seam.weld_poses[0], plan.move_speed_m_s, plan.acceleration_m_s2)
            _arc(client, plan, True)

            def progressed(index: int, seam_index: int = seam_index) -> None:
                nonlocal waypoint
                waypoint = index
                if on_progress is not None:
                    on_progress(seam_index, index)
                if on_pose is not None:
                    on_pose(seam_index, index, np.asarray(client.actual_tcp_pose(), dtype=float))

            client.move_path(path_entries(seam, plan), on_progress=progressed)
            _arc(client, plan, False)
            client.move_linear(seam.retreat_pose, plan.move_speed_m_s, plan.acceleration_m_s2)
    except KeyboardInterrupt:
        _safe_stop(client, plan)
        raise
    except RobotFault as fault:
        state = _safe_stop(client, plan)
        if seam_index < 0:
            raise RobotFault(f"{fault} ({state}; nothing retried)") from None
        seam = plan.seams[seam_index]
        where = f"waypoint {waypoint} of {len(seam.weld_poses)}" if waypoint >= 0 else "before the weld path"
        raise RobotFault(f"seam {seam.seam_id}, {where}: {fault} ({state}; nothing retried)") from None
