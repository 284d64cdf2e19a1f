"""`UrClient`: the robot connection `send` drives, over ur-rtde 1.6.5's control, receive and IO interfaces.

Every move is started asynchronously and then watched (progress, protective stop, program state,
connection) in a short Python loop, so Ctrl-C and SIGTERM act within one poll even mid-move: ur-rtde's
blocking calls hold the interpreter until they return. Any fault raises RobotFault; nothing is retried.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import suppress

import numpy as np

from weldseam.errors import InputError, RobotConnectionError, RobotFault
from weldseam.robot.limits import STANDARD_DIGITAL_OUTPUTS
from weldseam.robot.motion import pose_matrices

POLL_S = 0.008
START_TIMEOUT_S = 2.0
CAUSE_WAIT_S = 0.1
OUTPUT_TIMEOUT_S = 1.0
STOP_DECELERATION_M_S2 = 2.0
ARRIVED_M, ARRIVED_RAD = 1e-4, 2e-3


class UrClient:
    """One UR controller at `host`; connect() before use, close() after."""

    def __init__(self, host: str):
        self.host = host
        self._control = self._receive = self._io = None
        # Once the connection is lost, ur-rtde's calls try to reconnect and block for minutes: make none.
        self._lost = False

    @property
    def connection_lost(self) -> bool:
        return self._lost

    def connect(self) -> None:
        """Open the control, receive and IO sessions; RobotConnectionError (nothing moved) if the controller refuses."""
        try:
            import rtde_control
            import rtde_io
            import rtde_receive

            self._control = rtde_control.RTDEControlInterface(self.host)
            self._receive = rtde_receive.RTDEReceiveInterface(self.host)
            self._io = rtde_io.RTDEIOInterface(self.host)
        except (RuntimeError, ValueError, OSError) as error:
            raise RobotConnectionError(
                f"{self.host}: the controller answered but ur-rtde could not start its session ({error}); nothing moved"
            ) from None

    def close(self) -> None:
        if self._lost:
            return
        for interface in (self._control, self._io, self._receive):
            if interface is None:
                continue
            try:
                if interface is self._control and interface.isConnected():
                    interface.stopScript()
                interface.disconnect()
            except RuntimeError:
                pass

    def set_tcp(self, pose: np.ndarray) -> None:
        self._call("setTcp", self._control.setTcp, [float(v) for v in pose])

    def set_payload(self, mass_kg: float, cog_m: np.ndarray) -> None:
        """Payload mass (kg) and centre of gravity (3,) m from the flange."""
        self._call("setPayload", self._control.setPayload, float(mass_kg), [float(v) for v in cog_m])

    def move_linear(self, pose: np.ndarray, speed_m_s: float, acceleration_m_s2: float) -> None:
        target = [float(v) for v in pose]
        self._call("moveL", self._control.moveL, target, float(speed_m_s), float(acceleration_m_s2), True)
        self._watch("moveL", np.array(target))

    def move_path(self, entries: np.ndarray, on_progress: Callable[[int], None] | None = None) -> None:
        """One moveL path of (K, 9) entries [pose, speed, acceleration, blend]; on_progress(waypoint) as it runs."""
        rows = [[float(v) for v in row] for row in entries]
        self._call("moveL path", self._control.moveL, rows, True)
        self._watch("moveL path", np.asarray(entries)[-1, :6], on_progress, last_index=len(rows) - 1)

    def set_digital_output(self, index: int, on: bool) -> None:
        """Switch a standard digital output (0-7) and wait until the controller reports it switched."""
        if index not in STANDARD_DIGITAL_OUTPUTS:
            raise InputError(f"digital output {index}: not a standard digital output (0 to 7)")
        self._check_connection(f"digital output {index}")
        self._call(f"digital output {index}", self._io.setStandardDigitalOut, int(index), bool(on))
        deadline = time.monotonic() + OUTPUT_TIMEOUT_S
        while self._receive.getDigitalOutState(int(index)) != bool(on):
            if time.monotonic() > deadline:
                raise RobotFault(f"digital output {index} did not switch {'on' if on else 'off'} within 1 s")
            self._check_connection(f"digital output {index}")
            time.sleep(POLL_S)

    def stop(self) -> None:
        self._check_connection("stopL")
        self._control.stopL(STOP_DECELERATION_M_S2)

    def actual_tcp_pose(self) -> np.ndarray:
        return np.array(self._receive.getActualTCPPose())

    def _call(self, what: str, function, *args) -> None:
        try:
            accepted = function(*args)
        except RuntimeError as error:
            self._check(what)
            raise RobotFault(f"{what}: {error}") from None
        if accepted is False:
            self._check(what)
            raise RobotFault(f"{what} refused by the controller")

    def _check_connection(self, what: str) -> None:
        try:
            self._lost = self._lost or not (self._control.isConnected() and self._receive.isConnected())
        except RuntimeError:
            self._lost = True
        if self._lost:
            raise RobotFault(f"connection to {self.host} lost during {what}")

    def _check(self, what: str) -> None:
        """Raise RobotFault if the connection is gone, the arm is protective-stopped or the program stopped."""
        self._check_connection(what)
        try:
            running = self._control.isProgramRunning()
            # The receive stream may report the stop's cause a cycle after the control stream saw the program end.
            deadline = time.monotonic() + (0.0 if running else CAUSE_WAIT_S)
            while not (protective_stop := self._receive.isProtectiveStopped()) and time.monotonic() < deadline:
                time.sleep(POLL_S)
        except RuntimeError:
            self._check_connection(what)
            raise
        if protective_stop:
            raise RobotFault(f"protective stop during {what}")
        if not running:
            raise RobotFault(
                f"the control script stopped during {what} (program stopped on the pendant, a failed IK or a pose "
                "outside the safety limits)"
            )

    def _progress(self, what: str) -> tuple[bool, int]:
        """(running, waypoint) from the controller's async progress register."""
        try:
            status = self._control.getAsyncOperationProgressEx()
        except RuntimeError:
            self._check_connection(what)
            raise
        running = status.isAsyncOperationRunning()
        return running, status.progress() if running else -1

    def _arrived(self, pose: np.ndarray) -> bool:
        actual, target = pose_matrices(self.actual_tcp_pose()), pose_matrices(pose)
        turn = np.arccos(np.clip((np.trace(actual[:3, :3].T @ target[:3, :3]) - 1.0) / 2.0, -1.0, 1.0))
        return bool(np.linalg.norm(actual[:3, 3] - target[:3, 3]) < ARRIVED_M and turn < ARRIVED_RAD)

    def _watch(
        self, what: str, final_pose: np.ndarray, on_progress: Callable[[int], None] | None = None, last_index: int = 0
    ) -> None:
        """Follow an asynchronous move until it ends; report each new waypoint index to on_progress."""
        started, seen_running, reported = time.monotonic(), False, -1

        def report(index: int) -> None:
            nonlocal reported
            if on_progress is not None and index > reported:
                reported = index
                on_progress(index)

        while True:
            running, index = self._progress(what)
            if running:
                seen_running = True
                report(index)
            try:
                self._check(what)
            except RobotFault:
                with suppress(RobotFault, RuntimeError):
                    report(self._progress(what)[1])
                raise
            if not running and (seen_running or self._arrived(final_pose)):
                break
            if not running and time.monotonic() - started > START_TIMEOUT_S:
                raise RobotFault(f"{what}: the controller did not start the move within {START_TIMEOUT_S:g} s")
            time.sleep(POLL_S)
        if on_progress is not None and reported < last_index:
            on_progress(last_index)
