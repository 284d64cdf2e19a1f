"""Execute a checked MotionPlan with a robot client: the fixed sequence, arc safety, Ctrl-C/SIGTERM.

The client (weldseam.robot.client.UrClient or a test double) provides set_tcp, set_payload(mass_kg, cog_m),
move_linear(pose6, speed_m_s, acceleration_m_s2), move_path(entries (K, 9), on_progress),
set_digital_output(index, on), stop() and actual_tcp_pose(); faults raise RobotFault.
No motion is ever retried.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np

from weldseam.errors import InputError, RobotFault, StageError
from weldseam.robot.limits import STANDARD_DIGITAL_OUTPUTS
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


@contextmanager
def _interrupts_held() -> Iterator[None]:
    """For the duration: Ctrl-C and SIGTERM are ignored, so a second one cannot cut the stop or the arc-off short."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {number: signal.signal(number, signal.SIG_IGN) for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def _arc(client, plan: MotionPlan, on: bool) -> None:
    if plan.arc_output is not None:
        client.set_digital_output(plan.arc_output, on)


def _safe_stop(client, plan: MotionPlan) -> str:
    """Stop the arm, then switch the arc off, each as far as the connection still allows; say what is known."""
    with _interrupts_held():
        try:
            client.stop()
            stopped = "arm stopped"
        except Exception:
            stopped = "stopL not confirmed"
        if plan.arc_output is None:
            return f"{stopped}, no arc output"
        try:
            _arc(client, plan, False)
            arc = "arc off"
        except Exception:
            arc = "ARC OUTPUT NOT CONFIRMED OFF: check the cell"
    return f"{stopped}, {arc}"


def _refuse_unsafe(plan: MotionPlan) -> None:
    """InputError, before the first call to the robot, for a plan no controller should receive."""
    if plan.arc_output is not None and plan.arc_output not in STANDARD_DIGITAL_OUTPUTS:
        raise InputError(f"arc output {plan.arc_output}: not a standard digital output (0 to 7); nothing was sent")
    if (plan.payload_kg is None) != (plan.payload_cog_m is None):
        raise InputError("a payload needs both its mass and its centre of gravity; nothing was sent")


def _where(plan: MotionPlan, seam_index: int, waypoint: int) -> str:
    if seam_index < 0:
        return "before the first seam"
    seam = plan.seams[seam_index]
    position = f"waypoint {waypoint} of {len(seam.weld_poses)}" if waypoint >= 0 else "before the weld path"
    return f"seam {seam.seam_id}, {position}"


def execute(
    plan: MotionPlan,
    client,
    *,
    on_progress: Callable[[int, int], None] | None = None,
    on_pose: Callable[[int, int, np.ndarray], None] | None = None,
) -> None:
    """Run the plan: setTcp, setPayload (only if the plan has one), arc off; per seam approach, first weld pose,
    arc on, one moveL path, arc off, retreat.

    on_progress(seam_index, waypoint_index) follows the controller's async progress; on_pose(seam_index,
    waypoint_index, actual_tcp_pose6) receives the measured TCP at each progress report.
    Whatever ends the run early stops the arm, then switches the arc off, and says where and what is known:
    Ctrl-C (or SIGTERM) re-raises KeyboardInterrupt("at seam S, waypoint W of K: arm stopped, arc off"), a
    RobotFault is re-raised naming the seam and the waypoint, and any other exception (a bug) becomes
    StageError("send", ...). A plan with an impossible arc output or half a payload is refused (InputError)
    before the first call to the client.
    """
    _refuse_unsafe(plan)
    seam_index, waypoint = -1, -1
    try:
        client.set_tcp(np.asarray(plan.tcp_pose, dtype=float))
        if plan.payload_kg is not None:
            client.set_payload(plan.payload_kg, np.asarray(plan.payload_cog_m, dtype=float))
        # Outputs outlive programs: a killed earlier run may have left the arc on. Off before the first move.
        _arc(client, plan, False)
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
        state = _safe_stop(client, plan)
        where = _where(plan, seam_index, waypoint)
        raise KeyboardInterrupt(f"{'at ' if seam_index >= 0 else ''}{where}: {state}") from None
    except RobotFault as fault:
        state = _safe_stop(client, plan)
        raise RobotFault(f"{_where(plan, seam_index, waypoint)}: {fault} ({state}; nothing retried)") from None
    except Exception as error:
        state = _safe_stop(client, plan)
        raise StageError(
            "send",
            f"{_where(plan, seam_index, waypoint)}: unexpected {type(error).__name__}: {error} ({state}; "
            "nothing retried). This is a bug: please report it",
        ) from error
