"""End to end: `weldseam plan` a sample, then `weldseam send` it through ur-rtde 1.6.5 to robot-sim."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.io.paths import read_paths, write_paths
from weldseam.robot.moves import Shaping, motion_plan
from weldseam.robot.sim_controller import Faults
from weldseam.types import RunResult

BASE = "0.45,0.1,0.05,0,0,0"
SHAPING = ["--robot-base", BASE, "--standoff-mm", "12", "--arc-do", "1", "--speed-mm-s", "10"]
# ur-rtde 1.6.5 writes moveL path poses into its script with 6 significant digits: positions (< 1 m)
# arrive within 5e-7 m; rotation-vector components near pi within 5e-6 rad.
POSITION_TOLERANCE_M = 1e-6
ROTATION_TOLERANCE_RAD = 1e-5


def weldseam(*args: str, **options) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "weldseam.cli", *args], capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, timeout=120, **options)  # fmt: skip


@pytest.fixture(scope="module")
def two_seams(tmp_path_factory) -> str:
    """The V-groove sample planned, plus the same seam 60 mm over: a two-seam path file."""
    folder = tmp_path_factory.mktemp("send")
    planned = folder / "path.json"
    result = weldseam("plan", "samples/v_butt.ply", "--camera-pose", "samples/v_butt.pose.json", "-o", str(planned))
    assert result.returncode == 0, result.stderr
    record = json.loads(planned.read_text())
    second = json.loads(json.dumps(record["seams"][0]))
    second["id"] = 1
    for pose in second["poses"]:
        pose["y"] += 0.06
    record["seams"].append(second)
    path = folder / "two_seams.json"
    path.write_text(json.dumps(record))
    return str(path)


def expected_plan(path: str):
    setup = Shaping(base_pose=tuple(float(v) for v in BASE.split(",")), standoff_m=0.012, arc_output=1,
                    weld_speed_m_s=0.01)  # fmt: skip
    return motion_plan(read_paths(path), setup)


def distance_to_polyline(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """(N,) distance of each point (N, 3) from the poly-line (K, 3), m."""
    starts, ends = polyline[:-1], polyline[1:]
    along = np.clip(np.einsum("ksd,sd->ks", points[:, None] - starts, ends - starts)
                    / np.einsum("sd,sd->s", ends - starts, ends - starts), 0, 1)  # fmt: skip
    return np.linalg.norm(points[:, None] - (starts + along[..., None] * (ends - starts)), axis=2).min(axis=1)


def assert_same_pose(received, planned, what: str) -> None:
    received, planned = np.asarray(received, dtype=float), np.asarray(planned, dtype=float)
    assert np.linalg.norm(received[:3] - planned[:3]) <= POSITION_TOLERANCE_M, what
    turn = Rotation.from_rotvec(planned[3:]).inv() * Rotation.from_rotvec(received[3:])
    assert turn.magnitude() <= ROTATION_TOLERANCE_RAD, what


def events_of(sim, *kinds: str) -> list[dict]:
    return [event for event in sim.events if event["event"] in kinds]


def test_send_delivers_the_planned_motion_with_the_arc_on_exactly_around_each_weld(robot_sim, two_seams, tmp_path):
    sim = robot_sim(speedup=100.0)
    log = tmp_path / "tcp.csv"
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, "--yes", "--log", str(log))
    assert result.returncode == 0, result.stderr
    plan = expected_plan(two_seams)
    kinds = [event["event"] for event in sim.events]
    assert kinds == ["set_tcp"] + [  # and no set_payload: the robot's own payload setting stays
        "movel", "movel", "digital_output", "path", "digital_output", "movel"] * 2  # fmt: skip
    assert sim.events[0]["pose"] == pytest.approx(plan.tcp_pose.tolist(), abs=1e-12)
    for number, seam in enumerate(plan.seams):
        approach, first, on, path, off, retreat = sim.events[1 + 6 * number : 7 + 6 * number]
        assert approach["pose"] == pytest.approx(seam.approach_pose.tolist(), abs=1e-12)
        assert first["pose"] == pytest.approx(seam.weld_poses[0].tolist(), abs=1e-12)
        assert retreat["pose"] == pytest.approx(seam.retreat_pose.tolist(), abs=1e-12)
        entries = np.array(path["entries"])
        assert len(entries) == len(seam.weld_poses) > 2
        for index, (received, planned) in enumerate(zip(entries[:, :6], seam.weld_poses, strict=True)):
            assert_same_pose(received, planned, f"seam {number} waypoint {index}")
        assert np.allclose(entries[:, 6], 0.01, rtol=1e-5) and np.allclose(entries[:, 7], plan.acceleration_m_s2)
        blends = entries[:, 8]
        assert np.allclose(blends, seam.blend_radii_m, rtol=1e-5, atol=1e-9)
        segments = np.linalg.norm(np.diff(entries[:, :3], axis=0), axis=1)
        assert blends[-1] == 0.0 and blends[0] == 0.0
        assert np.all(blends[1:-1] < np.minimum(segments[:-1], segments[1:]) / 2), "neighbouring blends never overlap"
        assert blends.max() > 0.0, "the weld path is blended, not stop-and-go"
        assert (on["index"], on["on"], on["moving"]) == (1, True, False)
        assert_same_pose(on["tcp_pose"], seam.weld_poses[0], "arc on at the first weld pose")
        assert (off["index"], off["on"], off["moving"]) == (1, False, False)
        assert_same_pose(off["tcp_pose"], seam.weld_poses[-1], "arc off at the last weld pose")
    rows = np.loadtxt(log, delimiter=",", skiprows=1)
    assert len(rows) >= 4 and set(rows[:, 0]) == {0, 1}
    for seam_id, seam in enumerate(plan.seams):
        distance = distance_to_polyline(rows[rows[:, 0] == seam_id, 2:5], seam.weld_poses[:, :3])
        assert distance.max() < 1e-5, "the logged actual TCP lies on the weld path"


def test_the_payload_configured_on_the_robot_is_left_alone_unless_given(robot_sim, two_seams):
    sim = robot_sim(speedup=100.0)
    given = ["--payload-kg", "1.2", "--payload-cog-m", "0,0.01,0.08"]
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, *given, "--yes")
    assert result.returncode == 0, result.stderr
    assert [event["event"] for event in sim.events[:3]] == ["set_tcp", "set_payload", "movel"]
    assert [(event["mass_kg"], event["cog_m"]) for event in events_of(sim, "set_payload")] == [(1.2, [0.0, 0.01, 0.08])]


OUT_OF_RANGE = [
    (["--arc-do", "99"], "--arc-do 99: must be 0 to 7 (the standard digital outputs of the control box)"),
    (["--arc-do", "-1"], "--arc-do -1: must be 0 to 7 (the standard digital outputs of the control box)"),
    (["--standoff-mm", "-10"],
     "--standoff-mm -10: must be 0 to 50 mm (a negative stick-out puts the torch tip inside the work)"),
    (["--blend-mm", "-1"], "--blend-mm -1: must be 0 to 10 mm (a blend cuts the corner it rounds)"),
    (["--speed-mm-s", "5000"],
     "--speed-mm-s 5000: must be over 0 up to 100 mm/s (arc welding travels 2-25 mm/s, laser up to ~100)"),
    (["--speed-mm-s", "nan"],
     "--speed-mm-s nan: must be over 0 up to 100 mm/s (arc welding travels 2-25 mm/s, laser up to ~100)"),
    (["--payload-kg", "100", "--payload-cog-m", "0,0,0.1"],
     "--payload-kg 100: must be over 0 up to 10 kg (and at most the arm's rated payload: UR5/UR5e 5 kg, UR10 10 kg)"),
    (["--payload-kg", "7", "--payload-cog-m", "0,0,0.1"], "--payload-kg 7: over the ur5's rated payload of 5 kg"),
    (["--payload-kg", "1"], "--payload-kg and --payload-cog-m go together: a payload needs its mass and its centre "
                            "of gravity (leave both out to keep the payload configured on the robot)"),
    (["--log", "/nonexistent/tcp.csv"],
     "/nonexistent/tcp.csv: cannot write (No such file or directory); nothing was sent"),
    (["--log", "tcp.txt"], "tcp.txt: unknown log format '.txt' (use .csv or .jsonl); nothing was sent"),
]  # fmt: skip


@pytest.mark.parametrize("options, message", OUT_OF_RANGE, ids=[" ".join(options) for options, _ in OUT_OF_RANGE])
def test_an_option_outside_its_range_is_refused_before_anything_reaches_the_controller(
    robot_sim, two_seams, tmp_path, options, message
):
    sim = robot_sim(speedup=100.0)
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, *options, "--yes", cwd=tmp_path)
    assert (result.returncode, result.stderr.splitlines(), result.stdout) == (2, [f"Error: {message}"], "")
    assert sim.events == [] and list(tmp_path.iterdir()) == []


# Faults run at 10x real time: a waypoint then lasts ~50 ms, well over the client's 8 ms poll, so the
# waypoint it names is exact (at 100x several pass between two polls).
def test_protective_stop_stops_switches_the_arc_off_and_names_the_waypoint(robot_sim, two_seams, tmp_path):
    sim = robot_sim(speedup=10.0, faults=Faults(protective_stop_at=6))
    log = tmp_path / "tcp.jsonl"
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, "--yes", "--log", str(log))
    assert result.returncode == 5
    logged = [json.loads(line) for line in log.read_text().splitlines()]
    assert {row["seam_id"] for row in logged} == {0}, "the poses read back before the stop are kept"
    assert [row["waypoint"] for row in logged] == sorted({row["waypoint"] for row in logged})
    assert 0 < logged[-1]["waypoint"] <= 6
    summary, message = result.stderr.splitlines()  # ur-rtde's own lines stay out of the terminal
    assert "seam 0, waypoint 6 of" in message and "protective stop" in message and "arc off" in message, message
    assert result.stdout == ""
    kinds = [event["event"] for event in sim.events]
    after = kinds[kinds.index("protective_stop") + 1 :]
    assert after == ["digital_output"] and sim.events[-1]["on"] is False, "arc off, and nothing moved again"


def test_dropped_connection_fails_without_retry_and_says_the_arc_is_unconfirmed(robot_sim, two_seams):
    # Not within the first waypoints: a drop during ur-rtde's command handshake (the first ms of a
    # moveL) leaves ur-rtde 1.6.5 reconnecting inside that call forever, beyond our reach.
    sim = robot_sim(speedup=10.0, faults=Faults(disconnect_at=6))
    started = time.monotonic()
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, "--yes")
    assert result.returncode == 5
    # ur-rtde prints "Reconnecting..." and its exceptions itself; only our one line reaches the user.
    summary, message = result.stderr.splitlines()
    assert summary.startswith("2 seam(s), ") and result.stdout == ""
    assert "seam 0, waypoint 6 of" in message and "lost" in message and "NOT CONFIRMED OFF" in message, message
    assert [event["event"] for event in sim.events][-1] == "disconnect"
    assert time.monotonic() - started < 60


@pytest.mark.parametrize("latency_ms", [20, 200])
def test_a_slow_controller_still_gets_the_whole_job(robot_sim, two_seams, latency_ms):
    sim = robot_sim(speedup=100.0, faults=Faults(latency_s=latency_ms / 1000))
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, "--yes")
    assert result.returncode == 0, result.stderr
    assert [event["event"] for event in sim.events] == ["set_tcp"] + [
        "movel", "movel", "digital_output", "path", "digital_output", "movel"] * 2  # fmt: skip


@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_an_interrupt_mid_weld_stops_the_arm_switches_the_arc_off_and_says_where(robot_sim, two_seams, signal_number):
    sim = robot_sim(speedup=1.0)
    command = [sys.executable, "-m", "weldseam.cli", "send", two_seams, "--host", sim.host, *SHAPING, "--yes"]
    process = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)  # fmt: skip
    try:
        assert sim.wait_for("path", timeout_s=60) is not None
        time.sleep(1.5)
        process.send_signal(signal_number)
        _, stderr = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 130, stderr
    kinds = [event["event"] for event in sim.events]
    assert kinds[kinds.index("path") + 1 :] == ["stopl", "digital_output"]
    assert sim.events[-1]["on"] is False
    stopped_at = np.array(sim.events[-2]["tcp_pose"])
    assert_same_pose(sim.events[-1]["tcp_pose"], stopped_at, "the arm stays where it stopped")
    message = stderr.splitlines()[-1]
    said = re.fullmatch(r"Error: interrupted at seam 0, waypoint (\d+) of (\d+): arm stopped, arc off", message)
    assert said, message
    entries = np.array(events_of(sim, "path")[0]["entries"])
    waypoint, count = int(said.group(1)), int(said.group(2))
    assert count == len(entries) and 0 < waypoint < count
    # The arm was heading for the waypoint named (or had just passed it): it stopped on the path next to it.
    near = entries[max(waypoint - 1, 0) : waypoint + 2, :3]
    assert distance_to_polyline(stopped_at[None, :3], near)[0] < 1e-4


def test_a_send_after_one_killed_mid_weld_takes_over_the_controller_with_the_arc_off_first(robot_sim, two_seams):
    """A killed send leaves ur-rtde's script running and the arc output on; the next one stops the script (through
    the dashboard), starts its own and switches the arc off before it moves."""
    sim = robot_sim(speedup=1.0)
    command = [sys.executable, "-m", "weldseam.cli", "send", two_seams, "--host", sim.host, *SHAPING, "--yes"]
    killed = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert sim.wait_for("path", timeout_s=60) is not None
    finally:
        killed.kill()
        killed.wait(timeout=30)
    assert sim.controller.program_running and sim.controller.digital_outputs == 0b10, "script running, arc on"
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, "--speed-mm-s", "50", "--yes")
    assert result.returncode == 0, result.stderr
    events = sim.events[[event["event"] for event in sim.events].index("set_tcp", 1) :]
    assert [event["event"] for event in events] == ["set_tcp", "digital_output"] + [
        "movel", "movel", "digital_output", "path", "digital_output", "movel"] * 2  # fmt: skip
    assert (events[1]["index"], events[1]["on"], events[1]["moving"]) == (1, False, False)


def test_refusals_reach_no_controller(robot_sim, two_seams):
    sim = robot_sim(speedup=100.0)
    unreachable = weldseam("send", two_seams, "--host", sim.host, "--robot-base", "3,0,0,0,0,0", "--yes")
    assert unreachable.returncode == 4 and "refusing to move" in unreachable.stderr
    unconfirmed = weldseam("send", two_seams, "--host", sim.host, *SHAPING)
    assert unconfirmed.returncode == 2 and "--yes" in unconfirmed.stderr
    assert sim.events == []


def test_a_pose_the_controller_cannot_reach_stops_the_job_before_any_weld(robot_sim, two_seams):
    """`send --robot ur10` checks against a UR10's reach; the controller is a UR5 and refuses (its IK fails)."""
    sim = robot_sim(speedup=100.0, robot="ur5")
    far = ["--robot-base", "0.95,0.1,0.05,0,0,0", "--standoff-mm", "12", "--robot", "ur10"]
    assert weldseam("check", two_seams, *far).returncode == 0
    assert weldseam("check", two_seams, *far[:-1], "ur5").returncode == 4
    result = weldseam("send", two_seams, "--host", sim.host, *far, "--arc-do", "1", "--yes")
    assert result.returncode == 5
    assert "control script stopped" in result.stderr and "arc off" in result.stderr, result.stderr
    kinds = [event["event"] for event in sim.events]
    assert "fault" in kinds and "path" not in kinds
    assert not any(event["event"] == "digital_output" and event["on"] for event in sim.events), "the arc never lit"


def test_a_work_angle_reaches_the_controller_on_each_seams_side_and_send_names_it(robot_sim, two_seams, tmp_path):
    sim = robot_sim(speedup=100.0)
    result = weldseam("send", two_seams, "--host", sim.host, *SHAPING, "--work-angle-deg", "8", "--yes")
    assert result.returncode == 0, result.stderr
    assert result.stderr.splitlines()[1:] == [
        f"seam {seam}: v_groove, work angle 8 deg toward the side away from the robot" for seam in (0, 1)]
    setup = Shaping(base_pose=tuple(float(v) for v in BASE.split(",")), standoff_m=0.012, work_angle_deg=8.0)
    plan, flat = motion_plan(read_paths(two_seams), setup), expected_plan(two_seams)
    for path, seam, untilted in zip(events_of(sim, "path"), plan.seams, flat.seams, strict=True):
        entries = np.array(path["entries"])
        for index, (received, planned) in enumerate(zip(entries[:, :6], seam.weld_poses, strict=True)):
            assert_same_pose(received, planned, f"seam {seam.seam_id} waypoint {index}")
        # The groove runs across the robot's reach (along base y): the torch turns 8 deg toward base +x.
        turned = Rotation.from_rotvec(entries[:, 3:6]).as_matrix()[:, :, 2]
        plain = Rotation.from_rotvec(untilted.weld_poses[:, 3:]).as_matrix()[:, :, 2]
        assert np.all(turned[:, 0] > plain[:, 0] + np.sin(np.radians(7.0)))

    csv = tmp_path / "path.csv"
    write_paths(RunResult(paths=tuple(read_paths(two_seams))), csv)
    refused = weldseam("send", str(csv), "--host", sim.host, *SHAPING, "--work-angle-deg", "8", "--yes")
    assert refused.returncode == 2 and refused.stderr.startswith(f"Error: {csv}: seam 0 names no joint kind")
    assert len(events_of(sim, "path")) == 2, "the CSV refused before anything reached the controller"
