"""`RobotSim`: a fake UR controller on a loopback address that ur-rtde 1.6.5 connects to.

It serves RTDE (30004), the script ports (30003, 30002) and the dashboard (29999) on one loopback
address (127.0.0.2, 127.0.0.3, ... so several run side by side; ur-rtde's ports are fixed), runs a
SimController in simulated time (`speedup` x real time) and records every event to a JSON log.
It never binds beyond loopback.
"""

from __future__ import annotations

import ipaddress
import json
import queue
import re
import socket
import struct
import threading
import time
from collections.abc import Callable
from itertools import accumulate
from pathlib import Path
from typing import TypeVar

from weldseam.errors import InputError
from weldseam.io.atomic import atomic_write
from weldseam.robot import rtde_wire as wire
from weldseam.robot.check import HOME_JOINTS_RAD
from weldseam.robot.kinematics import ROBOTS
from weldseam.robot.sim_controller import Faults, SimController

RTDE_PORT, SCRIPT_PORTS, DASHBOARD_PORT = 30004, (30003, 30002), 29999
CONTROLLER_VERSIONS = {"cb3": (3, 15, 0, 0), "e-series": (5, 11, 0, 0)}
TICK_S = 0.002
_PROGRAM_END = re.compile(r"\nend[ \t]*(\n|$)")
T = TypeVar("T")


class RobotSim:
    """Start with `start()` (or `with RobotSim(...) as sim:`), stop with `stop()`; `events` is the record so far."""

    def __init__(
        self,
        host: str = "127.0.0.2",
        *,
        speedup: float = 1.0,
        faults: Faults = Faults(),
        controller: str = "cb3",
        robot: str = "ur5",
        log_path: str | Path | None = None,
        on_event=None,
    ):
        if not ipaddress.ip_address(host).is_loopback:
            raise InputError(f"robot-sim binds loopback addresses only (127.0.0.0/8), not {host}")
        if speedup <= 0:
            raise InputError(f"--speedup must be positive, got {speedup:g}")
        self.host, self.speedup, self.faults = host, speedup, faults
        self.version = CONTROLLER_VERSIONS[controller]
        self.robot = robot
        self.log_path = Path(log_path) if log_path else None
        self._on_event = on_event
        self._events: list[dict] = []
        self._events_lock = threading.Lock()
        self._stopping = threading.Event()
        self._listeners: list[socket.socket] = []
        self._connections: set[socket.socket] = set()
        self._threads: list[threading.Thread] = []
        self.controller = SimController(ROBOTS[robot], HOME_JOINTS_RAD, faults, self._record, self._disconnect_all)

    # -- lifecycle ---------------------------------------------------------------------------------
    def start(self) -> RobotSim:
        servers = [(RTDE_PORT, self._serve_rtde), (DASHBOARD_PORT, self._serve_dashboard)]
        servers += [(port, self._serve_script) for port in SCRIPT_PORTS]
        try:
            for port, handler in servers:
                listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                listener.bind((self.host, port))
                listener.listen(8)
                listener.settimeout(0.1)
                self._listeners.append(listener)
                self._spawn(self._accept, listener, handler)
        except OSError as error:
            self.stop()
            raise InputError(f"robot-sim cannot listen on {self.host}:{port}: {error.strerror}") from None
        self._spawn(self._clock)
        self._write_log()
        return self

    def stop(self) -> None:
        self._stopping.set()
        self._disconnect_all()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self._write_log()

    def __enter__(self) -> RobotSim:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def events(self) -> list[dict]:
        with self._events_lock:
            return list(self._events)

    def wait_for(self, kind: str, timeout_s: float = 10.0) -> dict | None:
        """The first event of this kind, waiting up to timeout_s (real time) for it."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            found = next((event for event in self.events if event["event"] == kind), None)
            if found is not None:
                return found
            time.sleep(0.01)
        return None

    # -- record --------------------------------------------------------------------------------------
    def _record(self, event: dict) -> None:
        with self._events_lock:
            self._events.append(event)
        if self._on_event is not None:
            self._on_event(event)
        self._write_log()

    def _write_log(self) -> None:
        if self.log_path is None:
            return
        with self._events_lock:
            record = {
                "host": self.host,
                "robot": self.robot,
                "controller_version": ".".join(map(str, self.version[:2])),
                "faults": {k: v for k, v in vars(self.faults).items() if v},
                "events": list(self._events),
            }
            atomic_write(self.log_path, (json.dumps(record, indent=1) + "\n").encode())

    # -- plumbing ------------------------------------------------------------------------------------
    def _spawn(self, target, *args) -> None:
        thread = threading.Thread(target=target, args=args, daemon=True)
        thread.start()
        self._threads.append(thread)

    def _accept(self, listener: socket.socket, handler) -> None:
        while not self._stopping.is_set():
            try:
                connection, _ = listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            connection.settimeout(None)
            self._connections.add(connection)
            threading.Thread(target=self._guarded, args=(handler, connection), daemon=True).start()

    def _guarded(self, handler, connection: socket.socket) -> None:
        try:
            handler(connection)
        except (OSError, ConnectionError, struct.error, ValueError):
            pass
        finally:
            self._connections.discard(connection)
            connection.close()

    def _disconnect_all(self) -> None:
        """Close every listener and connection (stop, or a disconnect fault: the cable is pulled)."""
        for sock in self._listeners + list(self._connections):
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            sock.close()
        self._connections.clear()

    def _clock(self) -> None:
        last = time.monotonic()
        while not self._stopping.wait(TICK_S):
            now = time.monotonic()
            self.controller.advance((now - last) * self.speedup)
            last = now

    # -- RTDE ------------------------------------------------------------------------------------
    def _serve_rtde(self, connection: socket.socket) -> None:
        reader = wire.PacketReader(connection)
        send_lock = threading.Lock()
        inputs: dict[int, tuple[list[str], object]] = {}
        output: dict = {}
        streaming = threading.Event()

        def send(kind: int, payload: bytes = b"") -> None:
            with send_lock:
                connection.sendall(wire.packet(kind, payload))

        def stream() -> None:
            while not self._stopping.is_set() and output:
                if streaming.is_set():
                    snapshot = zip(self.controller.values(output["names"]), output["zeros"])
                    values = [v for value, zero in snapshot for v in (zero if value is None else value)]
                    try:
                        send(wire.DATA, b"\x01" + output["struct"].pack(*values))
                    except OSError:
                        return
                time.sleep(1.0 / output["frequency"])

        read = _delay_line(reader.read, self.faults.latency_s) if self.faults.latency_s else reader.read
        while not self._stopping.is_set():
            kind, payload = read()
            if kind == wire.PROTOCOL_VERSION:
                send(kind, b"\x01")
            elif kind == wire.CONTROLLER_VERSION:
                send(kind, struct.pack(">IIII", *self.version))
            elif kind == wire.OUTPUT_SETUP:
                names = [name for name in payload[8:].decode().split(",") if name]
                types = [wire.field_type(name) for name in names]
                first = not output
                output.update(names=names, frequency=struct.unpack(">d", payload[:8])[0])
                if "NOT_FOUND" not in types:
                    output.update(struct=wire.recipe_struct(types), zeros=[_zeros(kind) for kind in types])
                send(kind, b"\x01" + ",".join(types).encode())
                if first:
                    threading.Thread(target=stream, daemon=True).start()
            elif kind == wire.INPUT_SETUP:
                names = [name for name in payload.decode().split(",") if name]
                types = [wire.field_type(name) for name in names]
                recipe = len(inputs) + 1
                widths = [len(wire.STRUCT_CODES.get(kind, "")) for kind in types]
                inputs[recipe] = (names, widths, wire.recipe_struct(types) if "NOT_FOUND" not in types else None)
                send(kind, bytes([recipe]) + ",".join(types).encode())
            elif kind == wire.START:
                # The reply first: ur-rtde reads exactly one packet as the answer to START.
                send(kind, b"\x01")
                streaming.set()
            elif kind == wire.PAUSE:
                streaming.clear()
                send(kind, b"\x01")
            elif kind == wire.DATA and payload and payload[0] in inputs:
                names, widths, layout = inputs[payload[0]]
                if layout is not None:
                    values, ends = layout.unpack_from(payload, 1), list(accumulate(widths))
                    self.controller.receive_inputs(
                        {name: values[end - width : end] for name, width, end in zip(names, widths, ends)}
                    )

    # -- script and dashboard -------------------------------------------------------------------------
    def _serve_script(self, connection: socket.socket) -> None:
        """ur-rtde keeps this connection open across uploads: a program ends at a top-level `end` line."""
        connection.settimeout(0.2)
        text = ""
        while not self._stopping.is_set():
            try:
                chunk = connection.recv(65536)
            except TimeoutError:
                if text.strip():
                    self.controller.load_script(text)
                text = ""
                continue
            if not chunk:
                if text.strip():
                    self.controller.load_script(text)
                return
            received_s = time.monotonic()
            text += chunk.decode(errors="replace")
            while (program_end := _PROGRAM_END.search(text)) is not None:
                program, text = text[: program_end.end()], text[program_end.end() :]
                time.sleep(max(0.0, received_s + self.faults.latency_s - time.monotonic()))
                self.controller.load_script(program)

    def _serve_dashboard(self, connection: socket.socket) -> None:
        connection.sendall(b"Connected: Universal Robots Dashboard Server\n")
        for line in connection.makefile("rb"):
            connection.sendall((self._dashboard_reply(line.decode(errors="replace").strip()) + "\n").encode())

    def _dashboard_reply(self, request: str) -> str:
        controller = self.controller
        major, minor = self.version[:2]
        replies = {
            "PolyscopeVersion": f"URSoftware {major}.{minor}.0.0 (Jan 01 2024)",
            "polyscopeVersion": f"URSoftware {major}.{minor}.0.0 (Jan 01 2024)",
            "is in remote control": "true",
            "get serial number": "20185500001",
            "get robot model": self.robot.upper(),
            "robotmode": "Robotmode: RUNNING",
            "programState": "PLAYING rtde_control" if controller.program_running else "STOPPED <unnamed>",
            "running": f"Program running: {str(controller.program_running).lower()}",
            "safetystatus": "Safetystatus: PROTECTIVE_STOP" if controller.protective_stop else "Safetystatus: NORMAL",
            "safetymode": "Safetymode: PROTECTIVE_STOP" if controller.protective_stop else "Safetymode: NORMAL",
        }
        if request == "unlock protective stop":
            controller.unlock_protective_stop()
            return "Protective stop releasing"
        if request == "stop":
            # ur-rtde's constructor stops a control script it finds running through here, and raises unless the
            # reply is exactly "Stopped".
            controller.stop_program("dashboard stop")
            return "Stopped"
        return replies.get(request, f"{request}: ok")


def _delay_line(read: Callable[[], T], latency_s: float) -> Callable[[], T]:
    """`read`, each item released latency_s after it arrived (an exception too): a slow network, order kept and
    the delays not added up, rather than a queue that handles one packet per latency_s."""
    arrivals: queue.SimpleQueue = queue.SimpleQueue()

    def receive() -> None:
        while True:
            try:
                item = read()
            except Exception as error:
                arrivals.put((time.monotonic(), error))
                return
            arrivals.put((time.monotonic(), item))

    threading.Thread(target=receive, daemon=True).start()

    def delayed() -> T:
        arrived_s, item = arrivals.get()
        time.sleep(max(0.0, arrived_s + latency_s - time.monotonic()))
        if isinstance(item, Exception):
            raise item
        return item

    return delayed


def _zeros(kind: str) -> tuple:
    """The value of a field the sim does not model: zeros of its RTDE type."""
    return tuple(0.0 if code == "d" else 0 for code in wire.STRUCT_CODES[kind])
