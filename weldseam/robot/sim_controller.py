"""The simulated UR controller behind `weldseam robot-sim`: no sockets, only state and rules.

It mimics what ur-rtde 1.6.5's control script does with the RTDE registers (command id in
input_int_register_0; 1 ready / 2 done in output_int_register_0; async progress in
output_int_register_2), moves the TCP along each move in simulated time (straight lines at the
commanded speed, orientation slerped, no blending), records every command that would reach a robot,
and injects faults at a given path waypoint.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from weldseam.robot.kinematics import RobotModel, forward, inverse, nearest_solution
from weldseam.robot.motion import pose_matrices, pose_vectors

READY, DONE = 1, 2
MOVEL, SET_PAYLOAD, SET_TCP, STOPL, POSE_WITHIN_LIMITS, PATH, INVERSE_KINEMATICS, STOP_SCRIPT = (
    3, 17, 29, 33, 36, 45, 46, 255,
)  # fmt: skip
STATUS_POWER_ON, STATUS_PROGRAM_RUNNING = 1, 2
SAFETY_NORMAL_BIT, SAFETY_PROTECTIVE_STOP_BIT = 1, 4
SAFETY_MODE_NORMAL, SAFETY_MODE_PROTECTIVE_STOP = 1, 3
RUNTIME_STOPPED, RUNTIME_PLAYING = 1, 2
ROBOT_MODE_RUNNING = 7
JOINT_MODE_RUNNING = 253
# A pure rotation is timed as if the TCP travelled this far per radian (the sim has no joint speeds).
ROTATION_EQUIVALENT_M_PER_RAD = 0.05

_PATH_BODY = re.compile(r"def exec_move_path\(\):(.*?)\n\s*end\b", re.S)
_MOVEL = re.compile(r"movel\(p\[([^\]]*)\],\s*a=([^,]+),\s*v=([^,]+),\s*r=([^)]+)\)")


@dataclass(frozen=True)
class Faults:
    """Faults to inject. Waypoints count every moveL-path waypoint the sim receives, from 0.

    protective_stop_at: the arm stops on reaching this waypoint and the control script stops.
    disconnect_at: every connection drops on reaching this waypoint (a pulled cable).
    latency_s: every packet from a client is handled this long after it arrived (a slow network: packets sent
        together arrive together, in order).
    """

    protective_stop_at: int | None = None
    disconnect_at: int | None = None
    latency_s: float = 0.0


def path_from_script(script: str) -> np.ndarray:
    """(K, 9) moveL path entries [pose (6), speed, acceleration, blend] from the movel lines ur-rtde injects."""
    body = _PATH_BODY.search(script)
    rows = [
        [float(v) for v in match.group(1).split(",")] + [float(match.group(n)) for n in (3, 2, 4)]
        for match in _MOVEL.finditer(body.group(1) if body else "")
    ]
    return np.array(rows, dtype=np.float64).reshape(-1, 9)


def _duration_s(start: np.ndarray, target: np.ndarray, speed_m_s: float) -> float:
    """Time of one straight move: max(distance, rotation * 0.05 m/rad) / speed."""
    distance = float(np.linalg.norm(target[:3, 3] - start[:3, 3]))
    angle = float(Rotation.from_matrix(start[:3, :3].T @ target[:3, :3]).magnitude())
    return max(distance, angle * ROTATION_EQUIVALENT_M_PER_RAD) / max(speed_m_s, 1e-9)


def _interpolated(start: np.ndarray, target: np.ndarray, fraction: float) -> np.ndarray:
    """Pose a fraction of the way: position linear, orientation slerp."""
    pose = np.eye(4)
    pose[:3, 3] = start[:3, 3] + fraction * (target[:3, 3] - start[:3, 3])
    turn = Rotation.from_matrix(start[:3, :3].T @ target[:3, :3]).as_rotvec()
    pose[:3, :3] = start[:3, :3] @ Rotation.from_rotvec(fraction * turn).as_matrix()
    return pose


@dataclass
class _Move:
    """A running move: targets (K, 4, 4) TCP poses, speeds (K,); first_waypoint is None for a single movel."""

    targets: np.ndarray
    speeds_m_s: np.ndarray
    first_waypoint: int | None
    synchronous: bool
    start: np.ndarray
    index: int = 0
    elapsed_s: float = 0.0


class SimController:
    """Controller state behind the RTDE, script and dashboard servers; thread-safe.

    on_event(dict) receives each record (command, output change, fault) as it happens;
    on_disconnect() is called when a disconnect fault fires.
    """

    def __init__(
        self,
        model: RobotModel,
        home_joints_rad: np.ndarray,
        faults: Faults,
        on_event: Callable[[dict], None],
        on_disconnect: Callable[[], None],
    ):
        self.lock = threading.RLock()
        self.model = model
        self.faults = faults
        self._on_event = on_event
        self._on_disconnect = on_disconnect
        self.time_s = 0.0
        self.joints_rad = np.asarray(home_joints_rad, dtype=np.float64).copy()
        self.tcp_offset = np.eye(4)
        self.tcp = forward(model, self.joints_rad)
        self.payload_kg, self.payload_cog_m = 0.0, np.zeros(3)
        self.inputs: dict[str, tuple] = {}
        self.out_int = [0] * 48
        self.out_double = [0.0] * 48
        self.program_running = False
        self.executing = False
        self.protective_stop = False
        self.digital_outputs = 0
        self.script_path = np.zeros((0, 9))
        self.move: _Move | None = None
        self.waypoints_received = 0
        self.async_op_id = 0
        self.async_changes = 0

    # -- what a client reads -------------------------------------------------------------------
    def values(self, names: list[str]) -> list[tuple | None]:
        """The RTDE output fields `names`, one consistent snapshot: a tuple each, None where the sim has no model."""
        with self.lock:
            running = self.program_running
            pose = tuple(pose_vectors(self.tcp))
            state = {
                "timestamp": (self.time_s,),
                "actual_q": tuple(self.joints_rad),
                "target_q": tuple(self.joints_rad),
                "actual_TCP_pose": pose,
                "target_TCP_pose": pose,
                "actual_digital_output_bits": (self.digital_outputs,),
                "runtime_state": (RUNTIME_PLAYING if running else RUNTIME_STOPPED,),
                "robot_status_bits": (STATUS_POWER_ON | (STATUS_PROGRAM_RUNNING if running else 0),),
                "safety_status_bits": (SAFETY_PROTECTIVE_STOP_BIT if self.protective_stop else SAFETY_NORMAL_BIT,),
                "safety_mode": (SAFETY_MODE_PROTECTIVE_STOP if self.protective_stop else SAFETY_MODE_NORMAL,),
                "safety_status": (SAFETY_MODE_PROTECTIVE_STOP if self.protective_stop else SAFETY_MODE_NORMAL,),
                "robot_mode": (ROBOT_MODE_RUNNING,),
                "joint_mode": (JOINT_MODE_RUNNING,) * 6,
                "speed_scaling": (1.0,),
                "target_speed_fraction": (1.0,),
                "speed_scaling_combined": (1.0,),
                "payload": (self.payload_kg,),
                "payload_cog": tuple(self.payload_cog_m),
            }
            return [self._register(name) or state.get(name) for name in names]

    def value(self, name: str) -> tuple | None:
        """One RTDE output field, as a tuple (None where the sim has no model)."""
        return self.values([name])[0]

    def _register(self, name: str) -> tuple | None:
        if name.startswith("output_int_register_"):
            return (self.out_int[int(name.rsplit("_", 1)[1])],)
        if name.startswith("output_double_register_"):
            return (self.out_double[int(name.rsplit("_", 1)[1])],)
        return None

    def tcp_pose(self) -> list[float]:
        with self.lock:
            return [round(float(v), 12) for v in pose_vectors(self.tcp)]

    # -- what a client writes ------------------------------------------------------------------
    def receive_inputs(self, values: dict[str, tuple]) -> None:
        """One RTDE data packet from a client: digital outputs apply at once; commands follow the handshake."""
        with self.lock:
            self.inputs.update(values)
            if "standard_digital_output_mask" in values:
                self._set_outputs(values["standard_digital_output_mask"][0], values["standard_digital_output"][0])
            if "input_int_register_0" in values:
                self._handshake(int(values["input_int_register_0"][0]))

    def load_script(self, text: str) -> None:
        """A program arrived on the script port: ur-rtde's control script starts; anything else is recorded."""
        with self.lock:
            if not text.lstrip().startswith("def rtde_control"):
                self._event("script", lines=len(text.splitlines()))
                return
            self.script_path = path_from_script(text)
            self.move = None
            self.program_running, self.executing = True, False
            self.async_op_id = self.async_changes = 0
            self._write_progress(-1)
            self.out_int[0] = READY

    def stop_program(self, reason: str) -> None:
        """The program stops as on the pendant's stop button: the arm halts where it is."""
        with self.lock:
            if self.program_running:
                self._halt()
                self._stop_program()
                self._event("program_stopped", reason=reason, tcp_pose=self.tcp_pose())

    def unlock_protective_stop(self) -> None:
        with self.lock:
            if self.protective_stop:
                self.protective_stop = False
                self._event("protective_stop_released")

    # -- time ---------------------------------------------------------------------------------
    def advance(self, seconds: float) -> None:
        """Let simulated time pass: the TCP moves along the running move at its commanded speeds."""
        with self.lock:
            self.time_s += seconds
            remaining = seconds
            while self.move is not None and remaining > 0.0:
                move = self.move
                target = move.targets[move.index]
                duration = _duration_s(move.start, target, move.speeds_m_s[move.index])
                if move.elapsed_s + remaining < duration:
                    move.elapsed_s += remaining
                    self._place(_interpolated(move.start, target, move.elapsed_s / duration))
                    return
                remaining -= duration - move.elapsed_s
                self._place(target)
                self._arrived()

    # -- internals ------------------------------------------------------------------------------
    def _event(self, kind: str, **fields) -> None:
        self._on_event({"t_s": round(self.time_s, 6), "event": kind, **fields})

    def _double(self, index: int) -> float:
        return float(self.inputs.get(f"input_double_register_{index}", (0.0,))[0])

    def _int(self, index: int) -> int:
        return int(self.inputs.get(f"input_int_register_{index}", (0,))[0])

    def _pose_input(self) -> np.ndarray:
        return np.array([self._double(i) for i in range(6)])

    def _place(self, tcp: np.ndarray) -> None:
        """Put the TCP there; the joints follow (the IK solution nearest the previous joints)."""
        self.tcp = tcp
        joints = self._joints_for(tcp)
        if joints is not None:
            self.joints_rad = joints

    def _joints_for(self, tcp: np.ndarray) -> np.ndarray | None:
        flange = tcp @ np.linalg.inv(self.tcp_offset)
        return nearest_solution(inverse(self.model, flange), self.joints_rad, self.model)

    def _set_outputs(self, mask: int, bits: int) -> None:
        previous = self.digital_outputs
        self.digital_outputs = (previous & ~mask) | (bits & mask)
        for index in range(8):
            if (previous ^ self.digital_outputs) >> index & 1:
                on = bool(self.digital_outputs >> index & 1)
                moving = self.move is not None
                self._event("digital_output", index=index, on=on, tcp_pose=self.tcp_pose(), moving=moving)

    def _write_progress(self, value: int) -> None:
        """output_int_register_2 as ur-rtde's script writes it: op id << 24 | changes << 16 | running | progress."""
        self.async_changes = (self.async_changes + 1) % 128
        if value == 0:
            self.async_op_id = (self.async_op_id + 1) % 128
        register = self.async_op_id * 16777216 + self.async_changes * 65536
        if value >= 0:
            register += min(value, 32767) + 32768
        self.out_int[2] = register

    def _handshake(self, command: int) -> None:
        if not self.program_running:
            return
        if command == 0:
            self.executing = False
            self.out_int[0] = READY
            return
        if self.executing:
            return
        self.executing = True
        self._process(command)

    def _process(self, command: int) -> None:
        synchronous = self._int(1) != 1
        if command == MOVEL:
            pose = self._pose_input()
            self._event("movel", pose=[float(v) for v in pose], speed_m_s=self._double(6),
                        acceleration_m_s2=self._double(7), asynchronous=not synchronous)  # fmt: skip
            self._start_move(pose_matrices(pose)[None], np.array([self._double(6)]), None, synchronous)
        elif command == PATH:
            entries = self.script_path
            self._event("path", entries=[[float(v) for v in row] for row in entries], asynchronous=not synchronous)
            first = self.waypoints_received
            self.waypoints_received += len(entries)
            self._start_move(pose_matrices(entries[:, :6]), entries[:, 6], first, synchronous)
        elif command == SET_TCP:
            flange = self.tcp @ np.linalg.inv(self.tcp_offset)
            self.tcp_offset = pose_matrices(self._pose_input())
            self.tcp = flange @ self.tcp_offset
            self._event("set_tcp", pose=[float(v) for v in self._pose_input()])
            self._done()
        elif command == SET_PAYLOAD:
            self.payload_kg, self.payload_cog_m = self._double(0), np.array([self._double(i) for i in (1, 2, 3)])
            self._event("set_payload", mass_kg=self.payload_kg, cog_m=self.payload_cog_m.tolist())
            self._done()
        elif command == STOPL:
            self._event("stopl", deceleration_m_s2=self._double(0), tcp_pose=self.tcp_pose())
            self._halt()
            self._done()
        elif command == INVERSE_KINEMATICS:
            self._inverse_kinematics(pose_matrices(self._pose_input()))
        elif command == POSE_WITHIN_LIMITS:
            self.out_int[1] = int(self._joints_for(pose_matrices(self._pose_input())) is not None)
            self._done()
        elif command == STOP_SCRIPT:
            self._halt()
            self.program_running, self.out_int[0] = False, 0
        else:
            self._event("unsupported_command", command=command)
            self._done()

    def _done(self) -> None:
        self.out_int[0] = DONE

    def _inverse_kinematics(self, tcp: np.ndarray) -> None:
        joints = self._joints_for(tcp)
        pose = [float(v) for v in pose_vectors(tcp)]
        if joints is None:
            self._event("fault", reason="inverse kinematics failed: no solution", pose=pose)
            self._stop_program()
            return
        self.out_double[:6] = [float(q) for q in joints]
        self._event("inverse_kinematics", pose=pose, joints_rad=self.out_double[:6])
        self._done()

    def _start_move(self, targets: np.ndarray, speeds_m_s: np.ndarray, first: int | None, synchronous: bool) -> None:
        for index, target in enumerate(targets):
            if self._joints_for(target) is None:
                where = f"waypoint {first + index}" if first is not None else "movel target"
                self._event("fault", reason=f"{where} is out of reach", pose=[float(v) for v in pose_vectors(target)])
                self._stop_program()
                return
        self.move = _Move(targets, speeds_m_s, first, synchronous, start=self.tcp.copy())
        if not synchronous:
            self._write_progress(0)
        if first is not None:
            self._write_progress(0)
        if not synchronous:
            self._done()
        self.advance(0.0)

    def _arrived(self) -> None:
        move = self.move
        if move.first_waypoint is not None:
            waypoint = move.first_waypoint + move.index
            if waypoint == self.faults.protective_stop_at:
                self.protective_stop = True
                self._event("protective_stop", waypoint=waypoint, tcp_pose=self.tcp_pose())
                self._stop_program()
                return
            if waypoint == self.faults.disconnect_at:
                self._event("disconnect", waypoint=waypoint, tcp_pose=self.tcp_pose())
                self.move = None
                self._on_disconnect()
                return
        move.index += 1
        move.start, move.elapsed_s = self.tcp.copy(), 0.0
        if move.index < len(move.targets):
            if move.first_waypoint is not None:
                self._write_progress(move.index)
            return
        self.move = None
        if move.synchronous:
            self._done()
        else:
            self._write_progress(-1)

    def _halt(self) -> None:
        """Stop the running move where the TCP is now."""
        if self.move is not None and not self.move.synchronous:
            self._write_progress(-1)
        self.move = None

    def _stop_program(self) -> None:
        self.move = None
        self.program_running, self.executing, self.out_int[0] = False, False, 0
