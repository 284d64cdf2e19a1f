"""`weldseam check` and `weldseam send`: verify a path on the robot model, then stream it to a UR arm."""

from __future__ import annotations

import json
import math
import os
import sys
from typing import Annotated, NoReturn

import typer

from weldseam.commands.common import EXIT_ROBOT_FAULT, EXIT_TABLE, reported, stderr
from weldseam.errors import InputError, RobotConnectionError, RobotFault, UnreachableError, WeldseamError
from weldseam.robot.limits import LIMITS, checked, checked_payload
from weldseam.types import JOINT_KINDS

CHECK_EPILOG = (
    "Example:\n\n"
    "  weldseam check path.json --robot-base 0.4,-0.2,0.1,0,0,0 --standoff-mm 12 --work-angle-deg 10\n\n"
    "  weldseam check path.json --json > report.json\n\n"
    "Every number is refused outside its range (exit 2), the same ranges as `send`.\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)
SEND_EPILOG = (
    "Example:\n\n"
    "  weldseam send path.json --host 192.168.1.10 --robot-base 0.4,-0.2,0.1,0,0,0 --arc-do 0 --speed-mm-s 8\n\n"
    "  weldseam send path.json --host 127.0.0.2 --dry-run --script weld.script\n\n"
    "Rehearse without a robot: start `weldseam robot-sim --host 127.0.0.2 --log sim.json` and send to "
    "127.0.0.2; the log lists every command the controller received.\n\n"
    "Before connecting, send checks every option against its range, that --log can be written and that every "
    "pose is reachable; a refusal moves nothing (exit 2 or 4). No controller at --host: exit 6, nothing moved. "
    "On a fault (protective stop, program stopped, IK refused, connection lost) send stops the arm, "
    "switches the arc off, names the seam and waypoint and exits 5; it never retries. Ctrl-C or SIGTERM: "
    "stopL, arc off, names the seam and waypoint, exit 130. Whatever ends a job early, the last line says "
    "whether the arm stopped and the arc is off, or that it could not confirm it.\n\n"
    "The payload configured on the robot is left alone unless --payload-kg and --payload-cog-m are given.\n\n"
    f"Exit codes:\n\n{EXIT_TABLE}"
)
CLOSED_GAP_STEPS = 2.0
TABLE_COLUMNS = ("seam", "poses", "reached", "max joint\nstep deg", "min\nwrist", "min\nelbow", "min\nshoulder m",
                 "problems")  # fmt: skip

PathArg = Annotated[
    str,
    typer.Argument(help="Path file from `weldseam plan` (.json or .csv; only the JSON says which seams are closed)."),
]


def _ranged(text: str, option: str, of: str = "") -> str:
    """An option's help with its range from weldseam.robot.limits (the one table the checks use too)."""
    return f"{text} Range{' of ' + of if of else ''}: {LIMITS[option].text()}."


RobotBase = Annotated[
    str, typer.Option(help="Pose of the scan's base frame in the robot base: x,y,z (m),rx,ry,rz (rotation vector).")
]
Tcp = Annotated[
    str,
    typer.Option(help=_ranged("Torch tip relative to the flange, x,y,z (m),rx,ry,rz (default: straight torch "
                              "200 mm).", "--tcp", of="its distance from the flange")),  # fmt: skip
]
StandoffMm = Annotated[
    float,
    typer.Option(help=_ranged("Stick-out: TCP this far back from the seam along the torch, mm.", "--standoff-mm")),
]
WorkAngleDeg = Annotated[
    float,
    typer.Option(help=_ranged("Torch tilt about the travel direction (sideways, across the seam), degrees, the "
                              "same whichever way the seam is welded: + turns the torch toward the bottom plate "
                              "(fillet, lap: added to the lap's split), toward the plate farther from the robot "
                              "(v_groove, bevel, square_butt, outside_corner); see the README for the fallbacks. "
                              "A CSV names no joint kind: give --joint.", "--work-angle-deg")),  # fmt: skip
]
Joint = Annotated[
    str | None,
    typer.Option(help="The joint kind of seams whose kind the path file does not name (a CSV names none): "
                      f"{', '.join(JOINT_KINDS)}. Needed for a non-zero --work-angle-deg on a CSV."),  # fmt: skip
]
TravelAngleDeg = Annotated[
    float,
    typer.Option(help=_ranged("Torch lean along the seam, degrees: + push (the torch points ahead, toward the "
                              "travel), - drag.", "--travel-angle-deg")),  # fmt: skip
]
ToleranceMm = Annotated[float, typer.Option(help=_ranged("Decimation chord tolerance, mm.", "--tolerance-mm"))]
AngleToleranceDeg = Annotated[
    float, typer.Option(help=_ranged("Decimation orientation tolerance, degrees.", "--angle-tolerance-deg"))
]
ApproachMm = Annotated[
    float, typer.Option(help=_ranged("Approach/retreat distance along the torch axis, mm.", "--approach-mm"))
]
BlendMm = Annotated[
    float,
    typer.Option(help=_ranged("Largest blend radius, mm (never more than half the shorter segment).", "--blend-mm")),
]
SpeedMmS = Annotated[float, typer.Option(help=_ranged("Travel (weld) speed, mm/s.", "--speed-mm-s"))]
MoveSpeedMmS = Annotated[
    float, typer.Option(help=_ranged("Speed of approach, retreat and travel moves, mm/s.", "--move-speed-mm-s"))
]
RobotName = Annotated[str, typer.Option("--robot", help="Robot model: ur5, ur5e or ur10.")]


def _numbers(text: str, option: str, count: int, names: str) -> tuple[float, ...]:
    values = [value for value in text.replace(" ", "").split(",") if value]
    try:
        numbers = tuple(float(value) for value in values)
    except ValueError:
        numbers = ()
    if len(numbers) != count or not all(math.isfinite(number) for number in numbers):
        raise InputError(f"{option} {text!r}: expected {count} finite numbers {names}")
    return numbers


def _pose6(text: str, option: str) -> tuple[float, ...]:
    return _numbers(text, option, 6, "x,y,z,rx,ry,rz")


def _within(option: str, vector: tuple[float, ...], text: str) -> tuple[float, ...]:
    """vector, if the length of its first three numbers (metres) is inside the range of `option`."""
    limit = LIMITS[option]
    if math.dist(vector[:3], (0.0, 0.0, 0.0)) > limit.high:
        raise InputError(f"{option} {text!r}: must be {limit.text()} ({limit.why})")
    return vector


def _setup(*, robot: str, robot_base: str, tcp: str, standoff_mm: float, work_angle_deg: float,
           travel_angle_deg: float, tolerance_mm: float, angle_tolerance_deg: float, approach_mm: float,
           blend_mm: float, speed_mm_s: float, move_speed_mm_s: float, payload_kg: float | None = None,
           payload_cog_m: str | None = None, arc_do: int | None = None):  # fmt: skip
    """Every option checked against its range (InputError naming the first one outside), as one Shaping."""
    from weldseam.robot.kinematics import ROBOTS
    from weldseam.robot.moves import Shaping

    if robot not in ROBOTS:
        raise InputError(f"--robot {robot!r}: choose one of {', '.join(sorted(ROBOTS))}")
    if (payload_kg is None) != (payload_cog_m is None):
        raise InputError("--payload-kg and --payload-cog-m go together: a payload needs its mass and its centre "
                         "of gravity (leave both out to keep the payload configured on the robot)")  # fmt: skip
    cog = None
    if payload_cog_m is not None:
        cog = _within("--payload-cog-m", _numbers(payload_cog_m, "--payload-cog-m", 3, "x,y,z"), payload_cog_m)
    return Shaping(
        base_pose=_pose6(robot_base, "--robot-base"),
        tcp_pose=_within("--tcp", _pose6(tcp, "--tcp"), tcp),
        standoff_m=checked("--standoff-mm", standoff_mm) / 1000,
        work_angle_deg=checked("--work-angle-deg", work_angle_deg),
        travel_angle_deg=checked("--travel-angle-deg", travel_angle_deg),
        tolerance_m=checked("--tolerance-mm", tolerance_mm) / 1000,
        angle_tolerance_deg=checked("--angle-tolerance-deg", angle_tolerance_deg),
        approach_m=checked("--approach-mm", approach_mm) / 1000,
        max_blend_m=checked("--blend-mm", blend_mm) / 1000,
        payload_kg=None if payload_kg is None else checked_payload(payload_kg, robot),
        payload_cog_m=cog,
        weld_speed_m_s=checked("--speed-mm-s", speed_mm_s) / 1000,
        move_speed_m_s=checked("--move-speed-mm-s", move_speed_mm_s) / 1000,
        arc_output=None if arc_do is None else int(checked("--arc-do", arc_do)),
    )


def _with_joints(paths: list, path: str, joint: str | None, work_angle_deg: float) -> list:
    """`paths` with `joint` as the kind of each seam of unknown kind; InputError naming the file for a
    --joint nothing takes, and for a work angle on a seam whose kind stays unknown (its side depends on it)."""
    from dataclasses import replace

    unknown = [seam.seam_id for seam in paths if seam.joint not in JOINT_KINDS]
    if joint is not None:
        if joint not in JOINT_KINDS:
            raise InputError(f"--joint {joint!r}: choose one of {', '.join(JOINT_KINDS)}")
        if not unknown:
            raise InputError(f"{path}: every seam names its joint kind; --joint is for a path that names none "
                             "(a CSV)")  # fmt: skip
        return [replace(seam, joint=joint) if seam.seam_id in unknown else seam for seam in paths]
    if unknown and work_angle_deg != 0.0:
        seam = next(seam for seam in paths if seam.seam_id == unknown[0])
        named = "no joint kind (a CSV names none)" if seam.joint is None else f"the unknown joint kind {seam.joint!r}"
        raise InputError(f"{path}: seam {seam.seam_id} names {named}, and the side a work angle tilts to depends on "
                         f"it: give --joint ({', '.join(JOINT_KINDS)}) or the plan's .json")  # fmt: skip
    return paths


def _paths(path: str, joint: str | None, work_angle_deg: float):
    """The weld paths of a path file, each with a joint kind where a work angle needs one (_with_joints);
    a CSV seam whose ends nearly meet gets a warning (CSV cannot say closed)."""
    import numpy as np

    from weldseam.io.paths import read_paths

    paths = _with_joints(read_paths(path), path, joint, work_angle_deg)
    if path.lower().endswith(".csv"):
        for seam in paths:
            steps_m = np.linalg.norm(np.diff(seam.positions_m, axis=0), axis=1)
            gap_m = float(np.linalg.norm(seam.positions_m[-1] - seam.positions_m[0]))
            if len(steps_m) >= 2 and gap_m <= CLOSED_GAP_STEPS * float(np.median(steps_m)):
                stderr(f"Warning: {path}: seam {seam.seam_id} ends {gap_m * 1000:.1f} mm from its start; a CSV "
                       "cannot mark a seam closed, so that gap stays unwelded: use the plan's .json to weld it all "
                       "round")  # fmt: skip
    return paths


def _work_angle_lines(plan) -> list[str]:
    """Per seam, the side its work angle turned the torch to (none when no seam got a work angle)."""
    if all(seam.work_angle.work_angle_deg == 0.0 for seam in plan.seams):
        return []
    return [seam.work_angle.text() for seam in plan.seams]


def _checked(plan, robot: str):
    from weldseam.robot.check import check_motion
    from weldseam.robot.kinematics import ROBOTS

    return check_motion(plan, ROBOTS[robot])


def _first_failure(report) -> str:
    from weldseam.robot.check import describe

    return describe(report.failures[0]) + (
        f" (and {len(report.failures) - 1} more)" if len(report.failures) > 1 else ""
    )


def _table(plan, report):
    from rich.table import Table

    table = Table(title=f"{report.robot}: {len(report.rows)} poses, {len(report.failures)} failing")
    # Two-line headers keep the whole table, every header word intact, within an 80-column terminal.
    for column in TABLE_COLUMNS:
        table.add_column(column, no_wrap=True)
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
            f"{math.degrees(max(steps, default=0.0)):.2f}",
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
    standoff_mm: StandoffMm = 0.0,
    work_angle_deg: WorkAngleDeg = 0.0,
    joint: Joint = None,
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
        from weldseam.robot.moves import motion_plan

        setup = _setup(robot=robot, robot_base=robot_base, tcp=tcp, standoff_mm=standoff_mm,
                       work_angle_deg=work_angle_deg, travel_angle_deg=travel_angle_deg, tolerance_mm=tolerance_mm,
                       angle_tolerance_deg=angle_tolerance_deg, approach_mm=approach_mm, blend_mm=blend_mm,
                       speed_mm_s=speed_mm_s, move_speed_mm_s=move_speed_mm_s)  # fmt: skip
        plan = motion_plan(_paths(path, joint, work_angle_deg), setup)
        report = _checked(plan, robot)
        if as_json:
            seams = [seam.work_angle.to_dict() for seam in plan.seams]
            print(json.dumps({**report.to_dict(), "seams": seams}, indent=1))
        else:
            console = Console()
            console.print(_table(plan, report))
            for line in _work_angle_lines(plan):
                console.print(line, markup=False)
            for row in report.failures:
                console.print(describe(row), markup=False)
        if not report.ok:
            raise UnreachableError(_first_failure(report))


def send(
    path: PathArg,
    host: Annotated[str | None, typer.Option(help="Robot controller IP address (or host name).")] = None,
    robot_base: RobotBase = "0,0,0,0,0,0",
    tcp: Tcp = "0,0,0.2,0,0,0",
    payload_kg: Annotated[
        float | None,
        typer.Option(help=_ranged("Torch mass for setPayload, kg; with --payload-cog-m. Default: the payload "
                                  "configured on the robot stays.", "--payload-kg")),  # fmt: skip
    ] = None,
    payload_cog_m: Annotated[
        str | None,
        typer.Option(help=_ranged("Centre of gravity of the payload from the flange, x,y,z (m); with "
                                  "--payload-kg.", "--payload-cog-m", of="its distance from the flange")),  # fmt: skip
    ] = None,
    standoff_mm: StandoffMm = 0.0,
    work_angle_deg: WorkAngleDeg = 0.0,
    joint: Joint = None,
    travel_angle_deg: TravelAngleDeg = 0.0,
    tolerance_mm: ToleranceMm = 0.2,
    angle_tolerance_deg: AngleToleranceDeg = 1.0,
    approach_mm: ApproachMm = 50.0,
    blend_mm: BlendMm = 2.0,
    speed_mm_s: SpeedMmS = 10.0,
    move_speed_mm_s: MoveSpeedMmS = 100.0,
    robot: RobotName = "ur5",
    arc_do: Annotated[
        int | None,
        typer.Option(help=_ranged("Standard digital output that switches the arc (default: none, a dry path).",
                                  "--arc-do")),  # fmt: skip
    ] = None,
    yes: Annotated[bool, typer.Option("--yes", help="Do not ask for confirmation before moving.")] = False,
    dry_run: Annotated[
        bool, typer.Option("--dry-run", help="No connection: print the plan, write the URScript.")
    ] = False,
    script: Annotated[str | None, typer.Option(help="With --dry-run: URScript file (default stdout).")] = None,
    log: Annotated[
        str | None,
        typer.Option(help="Actual TCP poses during the weld: .jsonl or .csv file (its folder is checked before "
                          "connecting)."),  # fmt: skip
    ] = None,
) -> None:
    """Check the path, then run it on a UR arm: approach, arc on, one moveL path per seam, arc off, retreat."""
    with reported():
        from weldseam.io.atomic import atomic_write
        from weldseam.robot.moves import estimated_time_s, motion_plan
        from weldseam.robot.tcp_log import TcpLog
        from weldseam.robot.urscript import urscript

        if not dry_run and not host:
            raise InputError("--host is required (or use --dry-run)")
        if script is not None and not dry_run:
            raise InputError("--script needs --dry-run (a real run writes no script); nothing was sent")
        if log is not None and dry_run:
            raise InputError("--log needs a real run (a dry run reads no TCP back); nothing was sent")
        setup = _setup(robot=robot, robot_base=robot_base, tcp=tcp, standoff_mm=standoff_mm,
                       work_angle_deg=work_angle_deg, travel_angle_deg=travel_angle_deg, tolerance_mm=tolerance_mm,
                       angle_tolerance_deg=angle_tolerance_deg, approach_mm=approach_mm, blend_mm=blend_mm,
                       speed_mm_s=speed_mm_s, move_speed_mm_s=move_speed_mm_s, payload_kg=payload_kg,
                       payload_cog_m=payload_cog_m, arc_do=arc_do)  # fmt: skip
        tcp_log = TcpLog(log) if log is not None else None
        plan = motion_plan(_paths(path, joint, work_angle_deg), setup)
        report = _checked(plan, robot)
        if not report.ok:
            raise UnreachableError(f"refusing to move: {_first_failure(report)}")
        payload = "left as configured" if payload_kg is None else f"{payload_kg:g} kg"
        summary = (
            f"{len(plan.seams)} seam(s), {sum(len(s.weld_poses) for s in plan.seams)} weld poses, "
            f"weld {plan.weld_length_m * 1000:.1f} mm at {speed_mm_s:g} mm/s, "
            f"about {estimated_time_s(plan):.0f} s; arc output: {'none (dry path)' if arc_do is None else arc_do}; "
            f"payload: {payload}"
        )
        stderr(summary)
        for line in _work_angle_lines(plan):
            stderr(line)
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
        _run(plan, host, tcp_log)


def _run(plan, host: str, log) -> None:
    """Connect, execute, close; every way out says what happened in one line (see SEND_EPILOG) and keeps the log."""
    from rich.console import Console
    from rich.progress import Progress

    from weldseam.robot.client import UrClient
    from weldseam.robot.native_output import native_output_silenced
    from weldseam.robot.send import execute, sigterm_as_interrupt

    def record(seam_index: int, waypoint: int, pose) -> None:
        log.record(plan.seams[seam_index].seam_id, waypoint, pose)

    client = UrClient(host)
    try:
        with sigterm_as_interrupt(), native_output_silenced():
            try:
                # Inside the silencing, so the progress display ends on its own line before any last word.
                with Progress(disable=not sys.stderr.isatty(), console=Console(stderr=True)) as progress:
                    tasks = [progress.add_task(f"seam {s.seam_id}", total=len(s.weld_poses)) for s in plan.seams]
                    try:
                        _connect(client)
                        execute(
                            plan,
                            client,
                            on_progress=lambda seam, waypoint: progress.update(tasks[seam], completed=waypoint + 1),
                            on_pose=record if log is not None else None,
                        )
                    finally:
                        client.close()
            except RobotFault as fault:
                if client.connection_lost:
                    _leave_after_lost_connection(fault, log)
                raise
    except KeyboardInterrupt as interrupt:
        _keep(log)
        stderr(f"Error: interrupted {interrupt}".rstrip())  # "at seam S, waypoint W of K: arm stopped, arc off"
        raise typer.Exit(130) from None
    except WeldseamError:
        _keep(log)
        raise
    if log is not None:
        log.save()


def _connect(client) -> None:
    """Probe, then open ur-rtde's sessions; an interrupt meanwhile says that nothing moved."""
    try:
        _probe(client.host)
        client.connect()
    except KeyboardInterrupt:
        raise KeyboardInterrupt(f"while connecting to {client.host}; nothing moved") from None


def _leave_after_lost_connection(fault: RobotFault, log) -> NoReturn:
    """Report and exit 5 at once, still silenced: after a dropped connection ur-rtde 1.6.5's background threads
    abort the interpreter at exit ("terminate called ... End of file"), which would turn exit 5 into 134."""
    _keep(log)
    stderr(f"Error: {fault}")
    sys.stdout.flush()
    os._exit(EXIT_ROBOT_FAULT)


def _keep(log) -> None:
    """Save the TCP log of a job that ended early, if it recorded anything; failing to write it is said, not raised."""
    if log is None or not log.rows:
        return
    try:
        log.save()
    except InputError as error:
        stderr(f"Warning: {error}")


def _probe(host: str, port: int = 30004, timeout_s: float = 3.0) -> None:
    """RobotConnectionError (exit 6, nothing moved) when the host has no address or nothing answers on its RTDE port."""
    import socket

    try:
        address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0][4]
    except socket.gaierror:
        raise RobotConnectionError(f"cannot connect to {host}: unknown host (no address for that name); "
                                   "nothing moved") from None  # fmt: skip
    try:
        socket.create_connection(address[:2], timeout=timeout_s).close()
    except ConnectionRefusedError:
        raise RobotConnectionError(f"cannot connect to {host}:{port}: connection refused (is the controller on, "
                                   "and is this its address?); nothing moved") from None  # fmt: skip
    except TimeoutError:
        raise RobotConnectionError(f"cannot connect to {host}:{port}: no answer within {timeout_s:g} s; "
                                   "nothing moved") from None  # fmt: skip
    except OSError as error:
        raise RobotConnectionError(f"cannot connect to {host}:{port}: {error.strerror or error}; "
                                   "nothing moved") from None  # fmt: skip
