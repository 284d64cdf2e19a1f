"""`weldseam robot-sim`: run the fake UR controller until Ctrl-C."""

from __future__ import annotations

import signal
import threading
from typing import Annotated, Optional

import typer

from weldseam.commands.common import EXIT_TABLE, reported, stderr

EPILOG = (
    "Example (two terminals, or & in one shell):\n\n"
    "  weldseam robot-sim --host 127.0.0.2 --log sim.json --speedup 20\n\n"
    "  weldseam send path.json --host 127.0.0.2 --yes\n\n"
    "Faults: --protective-stop-at K and --disconnect-at K fire on reaching waypoint K, counted from 0 over "
    "every moveL path received; --latency-ms delays every packet from a client (a slow network).\n\n"
    "The log (JSON) lists every event that would reach a robot: set_tcp, set_payload, movel, path (entries "
    "of pose, speed, acceleration, blend), digital_output (with the TCP pose at that moment), stopl, "
    "inverse_kinematics, protective_stop, disconnect, fault, program_stopped (a dashboard stop).\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)


def robot_sim(
    host: Annotated[str, typer.Option(help="Loopback address to bind (127.x.y.z); one per simulated robot.")] = (
        "127.0.0.2"
    ),
    log: Annotated[Optional[str], typer.Option(help="JSON event log, rewritten after every event.")] = None,
    speedup: Annotated[float, typer.Option(help="Simulated time runs this many times faster than real time.")] = 1.0,
    robot: Annotated[str, typer.Option(help="Arm model: ur5, ur5e or ur10.")] = "ur5",
    controller: Annotated[str, typer.Option(help="Controller to imitate: cb3 (3.15) or e-series (5.11).")] = "cb3",
    protective_stop_at: Annotated[
        Optional[int], typer.Option(help="Protective stop on reaching this path waypoint.")
    ] = None,
    disconnect_at: Annotated[Optional[int], typer.Option(help="Drop every connection at this path waypoint.")] = None,
    latency_ms: Annotated[
        float, typer.Option(help="Handle every client packet this long after it arrived (ms): a slow network.")
    ] = 0.0,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No event lines on stderr.")] = False,
) -> None:
    """Serve a fake UR controller (RTDE, script, dashboard) on a loopback address, for tests and rehearsals."""
    with reported():
        from weldseam.errors import InputError
        from weldseam.robot.kinematics import ROBOTS
        from weldseam.robot.sim import CONTROLLER_VERSIONS, RobotSim
        from weldseam.robot.sim_controller import Faults

        if robot not in ROBOTS:
            raise InputError(f"--robot {robot}: expected one of {', '.join(ROBOTS)}")
        if controller not in CONTROLLER_VERSIONS:
            raise InputError(f"--controller {controller}: expected one of {', '.join(CONTROLLER_VERSIONS)}")
        if latency_ms < 0:
            raise InputError(f"--latency-ms must not be negative, got {latency_ms:g}")
        faults = Faults(protective_stop_at=protective_stop_at, disconnect_at=disconnect_at,
                        latency_s=latency_ms / 1000.0)  # fmt: skip
        sim = RobotSim(host, speedup=speedup, faults=faults, controller=controller, robot=robot, log_path=log,
                       on_event=None if quiet else _print_event)  # fmt: skip
        stopped = threading.Event()
        signal.signal(signal.SIGTERM, lambda *_: stopped.set())
        sim.start()
        if not quiet:
            stderr(f"robot-sim: {robot} ({controller}) on {host}: RTDE 30004, script 30003/30002, dashboard 29999; "
                   "Ctrl-C to stop")  # fmt: skip
        try:
            while not stopped.wait(0.2):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            sim.stop()


def _print_event(event: dict) -> None:
    fields = {key: value for key, value in event.items() if key not in ("t_s", "event", "entries")}
    if "entries" in event:
        fields["waypoints"] = len(event["entries"])
    details = " ".join(f"{key}={_short(value)}" for key, value in fields.items())
    stderr(f"robot-sim {event['t_s']:9.3f} s  {event['event']} {details}".rstrip())


def _short(value) -> str:
    if isinstance(value, list):
        return "[" + ",".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in value) + "]"
    return f"{value:.4g}" if isinstance(value, float) else str(value)
