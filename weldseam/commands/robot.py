"""`weldseam check` and `weldseam send`: verify a path on the robot model, then stream it to a UR arm."""

from __future__ import annotations

import json
import os
import sys
from typing import Annotated

import typer

from weldseam.commands.common import EXIT_ROBOT_FAULT, EXIT_TABLE, reported, stderr
from weldseam.errors import InputError, RobotFault, UnreachableError

CHECK_EPILOG = (
    "Example:\n\n"
    "  weldseam check path.json --robot-base 0.4,-0.2,0.1,0,0,0 --standoff-mm 12 --work-angle-deg 10\n\n"
    "  weldseam check path.json --json > report.json\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)
SEND_EPILOG = (
    "Example:\n\n"
    "  weldseam send path.json --host 192.168.1.10 --robot-base 0.4,-0.2,0.1,0,0,0 --arc-do 0 --speed-mm-s 8\n\n"
    "  weldseam send path.json --host 127.0.0.2 --dry-run --script weld.script\n\n"
    "Rehearse without a robot: start `weldseam robot-sim --host 127.0.0.2 --log sim.json` and send to "
    "127.0.0.2; the log lists every command the controller received.\n\n"
    "On a fault (protective stop, program stopped, IK refused, connection lost) send stops the arm, "
    "switches the arc off, names the seam and waypoint and exits 5; it never retries. Ctrl-C or SIGTERM: "
    "stopL, arc off, exit 130.\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)

PathArg = Annotated[str, typer.Argument(help="Path file from `weldseam plan` (.json or .csv).")]
RobotBase = Annotated[
    str, typer.Option(help="Pose of the scan's base frame in the robot base: x,y,z (m),rx,ry,rz (rotation vector).")
]
Tcp = Annotated[
    str, typer.Option(help="Torch tip relative to the flange, x,y,z,rx,ry,rz (default: straight torch 200 mm).")
]
PayloadKg = Annotated[float, typer.Option(help="Torch mass for setPayload, kg.")]
StandoffMm = Annotated[float, typer.Option(help="Stick-out: TCP this far back from the seam along the torch, mm.")]
WorkAngleDeg = Annotated[float, typer.Option(help="Torch tilt about the travel direction, degrees.")]
TravelAngleDeg = Annotated[float, typer.Option(help="Torch tilt across the seam, degrees: + push, - drag.")]
ToleranceMm = Annotated[float, typer.Option(help="Decimation chord tolerance, mm.")]
AngleToleranceDeg = Annotated[float, typer.Option(help="Decimation orientation tolerance, degrees.")]
ApproachMm = Annotated[float, typer.Option(help="Approach/retreat distance along the torch axis, mm.")]
BlendMm = Annotated[float, typer.Option(help="Largest blend radius, mm (never more than half the shorter segment).")]
SpeedMmS = Annotated[float, typer.Option(help="Travel (weld) speed, mm/s.")]
MoveSpeedMmS = Annotated[float, typer.Option(help="Speed of approach, retreat and travel moves, mm/s.")]
RobotName = Annotated[str, typer.Option("--robot", help="Robot model: ur5, ur5e or ur10.")]


def _pose6(text: str, option: str):
    values = [value for value in text.replace(" ", "").split(",") if value]
    try:
        numbers = tuple(float(value) for value in values)
    except ValueError:
        numbers = ()
    if len(numbers) != 6:
        raise InputError(f"{option} {text!r}: expected six numbers x,y,z,rx,ry,rz")
    return numbers


def _plan(path, robot_base, tcp, payload_kg, standoff_mm, work_angle_deg, travel_angle_deg, tolerance_mm,
          angle_tolerance_deg, approach_mm, blend_mm, speed_mm_s, move_speed_mm_s, arc_do):  # fmt: skip
    from weldseam.io.paths import read_paths
    from weldseam.robot.moves import Shaping, motion_plan

    if tolerance_mm <= 0 or speed_mm_s <= 0 or move_speed_mm_s <= 0:
        raise InputError("--tolerance-mm, --speed-mm-s and --move-speed-mm-s must be positive")
    setup = Shaping(
        base_pose=_pose6(robot_base, "--robot-base"),
        tcp_pose=_pose6(tcp, "--tcp"),
        standoff_m=standoff_mm / 1000,
        work_angle_deg=work_angle_deg,
        travel_angle_deg=travel_angle_deg,
        tolerance_m=tolerance_mm / 1000,
        angle_tolerance_deg=angle_tolerance_deg,
        approach_m=approach_mm / 1000,
        max_blend_m=blend_mm / 1000,
        payload_kg=payload_kg,
        weld_speed_m_s=speed_mm_s / 1000,
        move_speed_m_s=move_speed_mm_s / 1000,
        arc_output=arc_do,
    )
    return motion_plan(read_paths(path), setup)


def _checked(plan, robot: str):
    from weldseam.robot.check import check_motion
    from weldseam.robot.kinematics import ROBOTS

    if robot not in ROBOTS:
        raise InputError(f"--robot {robot!r}: choose one of {', '.join(sorted(ROBOTS))}")
    return check_motion(plan, ROBOTS[robot])


def _first_failure(report) -> str:
    from weldseam.robot.check import describe

    return describe(report.failures[0]) + (
        f" (and {len(report.failures) - 1} more)" if len(report.failures) > 1 else ""
    )


def _table(plan, report):
    from rich.table import Table

    table = Table(title=f"{report.robot}: {len(report.rows)} poses, {len(report.failures)} failing")
    for column in (
        "seam",
        "poses",
        "reachable",
        "max joint step deg",
        "min wrist",
        "min elbow",
        "min shoulder m",
        "problems",
    ):
        table.add_column(column)
    for seam in plan.seams:
        rows = [row for row in report.rows if row.seam_id == seam.seam_id]
        steps = [row.joint_step_rad for row in rows if row.joint_step_rad is not None and row.kind != "approach"]
        margins = {name: min((row.margins[name] for row in rows if name in row.margins), default=float("nan"))
                   for name in ("wrist", "elbow", "shoulder_m")}  # fmt: skip
        failing = [row for row in rows if not row.ok]
        table.add_row(
            str(seam.seam_id),
            str(len(rows)),
            f"{sum(row.joints is not None for row in rows)}/{len(rows)}",
            f"{max(steps, default=0.0) * 57.29577951308232:.2f}",
            f"{margins['wrist']:.3f}",
            f"{margins['elbow']:.3f}",
            f"{margins['shoulder_m']:.3f}",
            str(len(failing)) if failing else "ok",
        )
    return table


def check(
    path: PathArg,
    robot_base: RobotBase = "0,0,0,0,0,0",
    tcp: Tcp = "0,0,0.2,0,0,0",
    payload_kg: PayloadKg = 0.0,
    standoff_mm: StandoffMm = 0.0,
    work_angle_deg: WorkAngleDeg = 0.0,
    travel_angle_deg: TravelAngleDeg = 0.0,
    tolerance_mm: ToleranceMm = 0.2,
    angle_tolerance_deg: AngleToleranceDeg = 1.0,
    approach_mm: ApproachMm = 50.0,
    blend_mm: BlendMm = 2.0,
    speed_mm_s: SpeedMmS = 10.0,
    move_speed_mm_s: MoveSpeedMmS = 100.0,
    robot: RobotName = "ur5",
    as_json: Annotated[bool, typer.Option("--json", help="Print the machine report (JSON) on stdout.")] = False,
) -> None:
    """Check every shaped pose on the robot model: reachable, joint continuity, singularity margins, limits."""
    with reported():
        from rich.console import Console

        from weldseam.robot.check import describe

        plan = _plan(path, robot_base, tcp, payload_kg, standoff_mm, work_angle_deg, travel_angle_deg, tolerance_mm,
                     angle_tolerance_deg, approach_mm, blend_mm, speed_mm_s, move_speed_mm_s, None)  # fmt: skip
        report = _checked(plan, robot)
        if as_json:
            print(json.dumps(report.to_dict(), indent=1))
        else:
            console = Console()
            console.print(_table(plan, report))
            for row in report.failures:
                console.print(describe(row), markup=False)
        if not report.ok:
            raise UnreachableError(_first_failure(report))


def send(
    path: PathArg,
    host: Annotated[str | None, typer.Option(help="Robot controller IP address.")] = None,
    robot_base: RobotBase = "0,0,0,0,0,0",
    tcp: Tcp = "0,0,0.2,0,0,0",
    payload_kg: PayloadKg = 0.0,
    standoff_mm: StandoffMm = 0.0,
    work_angle_deg: WorkAngleDeg = 0.0,
    travel_angle_deg: TravelAngleDeg = 0.0,
    tolerance_mm: ToleranceMm = 0.2,
    angle_tolerance_deg: AngleToleranceDeg = 1.0,
    approach_mm: ApproachMm = 50.0,
    blend_mm: BlendMm = 2.0,
    speed_mm_s: SpeedMmS = 10.0,
    move_speed_mm_s: MoveSpeedMmS = 100.0,
    robot: RobotName = "ur5",
    arc_do: Annotated[
        int | None, typer.Option(help="Standard digital output that switches the arc (default: none, a dry path).")
    ] = None,
    yes: Annotated[bool, typer.Option("--yes", help="Do not ask for confirmation before moving.")] = False,
    dry_run: Annotated[
        bool, typer.Option("--dry-run", help="No connection: print the plan, write the URScript.")
    ] = False,
    script: Annotated[str | None, typer.Option(help="With --dry-run: URScript file (default stdout).")] = None,
    log: Annotated[str | None, typer.Option(help="Actual TCP poses during the weld: .jsonl or .csv file.")] = None,
) -> None:
    """Check the path, then run it on a UR arm: approach, arc on, one moveL path per seam, arc off, retreat."""
    with reported():
        from weldseam.io.atomic import atomic_write
        from weldseam.robot.moves import estimated_time_s
        from weldseam.robot.urscript import urscript

        if not dry_run and not host:
            raise InputError("--host is required (or use --dry-run)")
        plan = _plan(path, robot_base, tcp, payload_kg, standoff_mm, work_angle_deg, travel_angle_deg, tolerance_mm,
                     angle_tolerance_deg, approach_mm, blend_mm, speed_mm_s, move_speed_mm_s, arc_do)  # fmt: skip
        report = _checked(plan, robot)
        if not report.ok:
            raise UnreachableError(f"refusing to move: {_first_failure(report)}")
        summary = (
            f"{len(plan.seams)} seam(s), {sum(len(s.weld_poses) for s in plan.seams)} weld poses, "
            f"weld {plan.weld_length_m * 1000:.1f} mm at {speed_mm_s:g} mm/s, "
            f"about {estimated_time_s(plan):.0f} s; arc output: {'none (dry path)' if arc_do is None else arc_do}"
        )
        stderr(summary)
        if dry_run:
            text = urscript(plan)
            if script:
                atomic_write(script, text.encode())
            else:
                sys.stdout.write(text)
            return
        if not yes:
            if not sys.stdin.isatty():
                raise InputError("no terminal to confirm on: pass --yes to move the robot without a prompt")
            if not typer.confirm(f"Move the robot at {host}?", err=True):
                raise InputError("not confirmed; nothing moved")
        _run(plan, host, log)


def _run(plan, host: str, log: str | None) -> None:
    from rich.console import Console
    from rich.progress import Progress

    from weldseam.io.atomic import atomic_write
    from weldseam.robot.send import execute, sigterm_as_interrupt

    _probe(host)
    from weldseam.robot.client import UrClient

    rows: list[dict] = []

    def record(seam_index, waypoint, pose):
        rows.append({"seam_id": plan.seams[seam_index].seam_id, "waypoint": waypoint, "pose": [float(v) for v in pose]})

    client = UrClient(host)
    try:
        with Progress(disable=not sys.stderr.isatty(), console=Console(stderr=True)) as progress:
            tasks = [progress.add_task(f"seam {s.seam_id}", total=len(s.weld_poses)) for s in plan.seams]
            try:
                with sigterm_as_interrupt():
                    client.connect()
                    execute(
                        plan,
                        client,
                        on_progress=lambda seam, waypoint: progress.update(tasks[seam], completed=waypoint + 1),
                        on_pose=record if log else None,
                    )
            finally:
                client.close()
                if log:
                    atomic_write(log, _log_text(rows, log).encode())
    except RobotFault as fault:
        if not client.connection_lost:
            raise
        # ur-rtde 1.6.5's background threads abort the interpreter at exit after a dropped connection
        # ("terminate called ... End of file"): report and leave before they can turn exit 5 into 134.
        stderr(f"Error: {fault}")
        sys.stdout.flush()
        os._exit(EXIT_ROBOT_FAULT)


def _probe(host: str, port: int = 30004, timeout_s: float = 3.0) -> None:
    """Fail fast (RobotFault, exit 5) when nothing answers on the controller's RTDE port."""
    import socket

    from weldseam.errors import RobotFault

    try:
        socket.create_connection((host, port), timeout=timeout_s).close()
    except OSError as error:
        raise RobotFault(f"cannot connect to {host}:{port} ({error}); nothing moved") from None


def _log_text(rows: list[dict], log: str) -> str:
    if log.endswith(".csv"):
        lines = ["seam,waypoint,x,y,z,rx,ry,rz"]
        lines += [
            ",".join([str(row["seam_id"]), str(row["waypoint"])] + [f"{v:.9g}" for v in row["pose"]]) for row in rows
        ]
        return "\n".join(lines) + "\n"
    return "".join(json.dumps(row) + "\n" for row in rows)
