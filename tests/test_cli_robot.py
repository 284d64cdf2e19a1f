from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from weldseam.io.paths import read_paths
from weldseam.robot.moves import Shaping, motion_plan

BASE = "0.45,0.1,0.05,0,0,0"
ROOT = Path(__file__).resolve().parents[1]


def run(*args: str, env_columns: int | None = None, cwd=None) -> subprocess.CompletedProcess:
    env = None if env_columns is None else {**os.environ, "COLUMNS": str(env_columns)}
    return subprocess.run(
        [sys.executable, "-m", "weldseam.cli", *args],
        check=False,
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        env=env,
        cwd=cwd,
    )


@pytest.fixture(scope="module")
def path_file(tmp_path_factory) -> str:
    output = tmp_path_factory.mktemp("robot") / "path.json"
    result = run("plan", "samples/v_butt.ply", "--camera-pose", "samples/v_butt.pose.json", "-o", str(output), "-q")
    assert result.returncode == 0, result.stderr
    return str(output)


def test_check_passes_in_reach_with_json(path_file):
    result = run("check", path_file, "--robot-base", BASE, "--standoff-mm", "12", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["ok"] and report["failures"] == 0 and report["robot"] == "ur5"


def test_check_fails_out_of_reach_naming_the_pose(path_file):
    result = run("check", path_file, "--robot-base", "2,0,0,0,0,0")
    assert result.returncode == 4
    assert result.stderr.startswith("Error: seam 0 approach: unreachable")
    assert "seam 0 weld 0: unreachable" in result.stdout


def test_send_refuses_unreachable_before_anything(path_file):
    result = run("send", path_file, "--host", "127.0.0.9", "--robot-base", "2,0,0,0,0,0", "--yes")
    assert result.returncode == 4
    assert result.stderr.strip().splitlines() == [result.stderr.strip()]
    assert result.stderr.startswith("Error: refusing to move: seam 0 approach: unreachable")


def test_send_without_yes_and_without_tty_refuses(path_file):
    result = run("send", path_file, "--host", "127.0.0.9", "--robot-base", BASE)
    assert result.returncode == 2
    assert "pass --yes" in result.stderr
    assert result.stdout == ""


def test_dry_run_writes_the_urscript_of_the_shaped_path(path_file, tmp_path):
    script = tmp_path / "weld.script"
    args = ["--robot-base", BASE, "--standoff-mm", "12", "--arc-do", "1", "--tolerance-mm", "0.2"]
    result = run("send", path_file, "--dry-run", "--script", str(script), *args)
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""
    assert "seam(s)" in result.stderr
    plan = motion_plan(read_paths(path_file), Shaping(base_pose=(0.45, 0.1, 0.05, 0, 0, 0), standoff_m=0.012))
    lines = script.read_text().splitlines()
    movels = [line for line in lines if line.strip().startswith("movel(")]
    assert len(movels) == sum(len(seam.weld_poses) + 2 for seam in plan.seams)
    on = lines.index("  set_standard_digital_out(1, True)")
    off = lines.index("  set_standard_digital_out(1, False)")
    weld = lines[on + 1 : off]
    poses = np.array([[float(v) for v in line.split("p[")[1].split("]")[0].split(",")] for line in weld])
    np.testing.assert_allclose(poses, plan.seams[0].weld_poses[1:], atol=1e-8)


def test_send_to_a_bad_host_exits_6_saying_nothing_moved(path_file):
    result = run("send", path_file, "--host", "127.0.0.254", "--robot-base", BASE, "--yes")
    assert result.returncode == 6
    assert result.stderr.splitlines()[-1] == (
        "Error: cannot connect to 127.0.0.254:30004: connection refused (is the controller on, and is this its "
        "address?); nothing moved"
    )
    assert "Traceback" not in result.stderr and result.stdout == ""


def test_send_to_an_unknown_host_exits_6_naming_it(path_file):
    result = run("send", path_file, "--host", "no-such-robot.invalid", "--robot-base", BASE, "--yes")
    assert result.returncode == 6
    assert result.stderr.splitlines()[-1] == (
        "Error: cannot connect to no-such-robot.invalid: unknown host (no address for that name); nothing moved"
    )


@pytest.mark.parametrize(
    "options, message",
    [  # fmt: skip
        (["--host", "127.0.0.254", "--script", "weld.script"],
         "Error: --script needs --dry-run (a real run writes no script); nothing was sent"),
        (["--dry-run", "--log", "tcp.csv"],
         "Error: --log needs a real run (a dry run reads no TCP back); nothing was sent"),
    ],
    ids=["script-without-dry-run", "log-with-dry-run"],
)
def test_send_refuses_an_output_it_would_not_write(path_file, tmp_path, options, message):
    result = run("send", path_file, "--robot-base", BASE, "--yes", *options, cwd=tmp_path)
    assert (result.returncode, result.stderr, result.stdout) == (2, message + "\n", "")
    assert list(tmp_path.iterdir()) == []


def test_check_refuses_the_same_ranges_as_send(path_file):
    result = run("check", path_file, "--robot-base", BASE, "--standoff-mm", "-10")
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == (
        "Error: --standoff-mm -10: must be 0 to 50 mm (a negative stick-out puts the torch tip inside the work)\n"
    )


def test_check_table_keeps_every_header_word_whole_in_80_columns(path_file):
    result = run("check", path_file, "--robot-base", BASE, "--standoff-mm", "12", env_columns=80)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert max(len(line) for line in lines) <= 80
    assert "\u2026" not in result.stdout, "no header or value cut short with an ellipsis"
    header = " ".join(lines[1:5])
    for word in ("seam", "poses", "reached", "max", "joint", "step", "deg", "wrist", "elbow", "shoulder", "problems"):
        assert f" {word} " in header, word


@pytest.mark.parametrize("command", ["check", "send"])
def test_help_says_the_travel_angle_leans_along_the_seam(command):
    result = run(command, "--help", env_columns=200)
    text = " ".join(result.stdout.split())
    assert "--travel-angle-deg FLOAT Torch lean along the seam, degrees: + push (the torch points ahead, toward " \
           "the travel), - drag. Range: -30 to 30 deg." in text.replace("<float>", "FLOAT")  # fmt: skip
    assert "Torch tilt about the travel direction (sideways, across the seam)" in text


def ring_result(closed: bool):
    """A 40 mm ring of 24 poses, torch down, around (0, 0, 0) of the scan frame."""
    from weldseam.types import RunResult, WeldPath

    angles = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
    positions = np.column_stack([0.02 * np.cos(angles), 0.02 * np.sin(angles), np.zeros(24)])
    travel = np.column_stack([-np.sin(angles), np.cos(angles), np.zeros(24)])
    down = np.tile([0.0, 0.0, -1.0], (24, 1))
    rotations = np.stack([np.cross(travel, down), travel, down], axis=2)
    return RunResult(paths=(WeldPath(7, positions, rotations, closed=closed),))


def test_a_csv_cannot_say_closed_so_check_warns_where_the_weld_would_stop_short(tmp_path):
    from weldseam.io.paths import write_paths

    write_paths(ring_result(closed=True), tmp_path / "ring.json")
    write_paths(ring_result(closed=True), tmp_path / "ring.csv")
    from_json = run("check", str(tmp_path / "ring.json"), "--robot-base", BASE, "--standoff-mm", "12")
    from_csv = run("check", str(tmp_path / "ring.csv"), "--robot-base", BASE, "--standoff-mm", "12")
    # (A torch turning once round the ring flips the wrist: check fails both, after reading them.)
    assert "Warning" not in from_json.stderr
    assert from_csv.stderr.splitlines()[0] == (
        f"Warning: {tmp_path / 'ring.csv'}: seam 7 ends 5.2 mm from its start; a CSV cannot mark a seam closed, "
        "so that gap stays unwelded: use the plan's .json to weld it all round"
    )
    setup = Shaping(base_pose=(0.45, 0.1, 0.05, 0, 0, 0), standoff_m=0.012)
    closed = motion_plan(read_paths(tmp_path / "ring.json"), setup).seams[0].weld_poses
    opened = motion_plan(read_paths(tmp_path / "ring.csv"), setup).seams[0].weld_poses
    np.testing.assert_allclose(closed[-1], closed[0], atol=1e-12)
    assert np.linalg.norm(opened[-1, :3] - opened[0, :3]) > 0.005, "what the warning says: the CSV ring stays open"


def test_an_open_csv_seam_gets_no_warning(tmp_path, path_file):
    from weldseam.io.paths import write_paths
    from weldseam.types import RunResult

    write_paths(RunResult(paths=tuple(read_paths(path_file))), tmp_path / "path.csv")
    result = run("check", str(tmp_path / "path.csv"), "--robot-base", BASE, "--standoff-mm", "12")
    assert result.returncode == 0 and result.stderr == ""


def readme_table(heading: str) -> list[list[str]]:
    """The rows (cells stripped, backticks removed) of the first table after `heading` in the README."""
    text = (ROOT / "README.md").read_text()
    section = text[text.index(heading) :]
    rows, started = [], False
    for line in section.splitlines()[1:]:
        if line.startswith("|"):
            started = True
            cells = [cell.strip().replace("`", "") for cell in line.strip("|").split("|")]
            if not set("".join(cells)) <= set("-: "):
                rows.append(cells)
        elif started:
            break
    return rows[1:]


def test_the_readme_exit_code_table_lists_every_code():
    from weldseam.commands.common import EXIT_CODES

    listed = [int(row[0]) for row in readme_table("### Exit codes")]
    assert listed == [code for code, _ in EXIT_CODES]


def test_the_readme_states_the_range_of_every_send_option():
    from weldseam.commands.robot import send
    from weldseam.robot.limits import LIMITS

    rows = {row[0]: row[1] for row in readme_table("#### Options of `send`")}
    options = ["--" + name.replace("_", "-") for name in inspect.signature(send).parameters if name != "path"]
    options = [{"--as-json": "--json"}.get(option, option) for option in options]
    assert sorted(rows) == sorted(options)
    for option, limit in LIMITS.items():
        assert rows[option] == limit.text(), option


def test_robot_sim_binds_loopback_only():
    result = run("robot-sim", "--host", "10.1.2.3")
    assert result.returncode == 2
    assert result.stderr.strip() == "Error: robot-sim binds loopback addresses only (127.0.0.0/8), not 10.1.2.3"


def test_robot_sim_serves_until_interrupted_then_leaves_its_log(tmp_path):
    import signal
    import time

    log = tmp_path / "sim.json"
    server = subprocess.Popen([sys.executable, "-m", "weldseam.cli", "robot-sim", "--host", "127.0.0.9", "--log",
                               str(log)], stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        deadline = time.monotonic() + 30
        while not log.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        busy = run("robot-sim", "--host", "127.0.0.9")
        assert busy.returncode == 2 and "cannot listen on 127.0.0.9" in busy.stderr
    finally:
        server.send_signal(signal.SIGINT)
        _, stderr = server.communicate(timeout=30)
    assert server.returncode == 0, stderr
    record = json.loads(log.read_text())
    assert record["host"] == "127.0.0.9" and record["robot"] == "ur5" and record["events"] == []


@pytest.fixture(scope="module")
def fillet_both_ways(tmp_path_factory) -> list[str]:
    """The T-fillet sample planned twice, welded +x and -x: the same seam, travel and across-axis flipped."""
    folder = tmp_path_factory.mktemp("fillet")
    outputs = []
    for direction in ("+x", "-x"):
        output = folder / f"fillet{direction}.json"
        result = run("plan", "samples/fillet_t.png", "--intrinsics", "samples/d415.intrinsics.json", "--camera-pose",
                     "samples/fillet_t.pose.json", f"--direction={direction}", "-o", str(output), "-q")  # fmt: skip
        assert result.returncode == 0, result.stderr
        outputs.append(str(output))
    return outputs


def weld_torch_axes(report: dict) -> np.ndarray:
    """(K, 3) torch axes (tool z) of the weld poses of a `check --json` report."""
    from scipy.spatial.transform import Rotation

    poses = np.array([row["pose"] for row in report["rows"] if row["kind"] == "weld"])
    return Rotation.from_rotvec(poses[:, 3:]).as_matrix()[:, :, 2]


def weld_seam_points(report: dict, standoff_m: float) -> np.ndarray:
    """(K, 3) the seam points (scan frame) the weld poses of a `check --json` report stand off from."""
    poses = np.array([row["pose"] for row in report["rows"] if row["kind"] == "weld"])
    base = np.array([float(value) for value in BASE.split(",")[:3]])
    return poses[:, :3] + standoff_m * weld_torch_axes(report) - base


def degrees_below_horizontal(axes: np.ndarray) -> np.ndarray:
    return np.degrees(np.arcsin(-axes[:, 2]))


def test_a_fillet_welded_either_way_gets_the_same_tilt_toward_its_bottom_plate(fillet_both_ways):
    planned = read_paths(fillet_both_ways[0])[0]
    below_deg = degrees_below_horizontal(planned.rotations[:, :, 2])
    assert abs(below_deg.mean() - 45.0) < 1.0, "the plan's bisector, 45 deg from the bottom plate"
    means = []
    for path in fillet_both_ways:
        result = run("check", path, "--robot-base", BASE, "--standoff-mm", "12", "--work-angle-deg", "10", "--json")
        assert result.returncode == 0, result.stderr
        report = json.loads(result.stdout)
        assert [(seam["joint"], seam["side"]) for seam in report["seams"]] == [("fillet", "lower_face")]
        axes, points = weld_torch_axes(report), weld_seam_points(report, 0.012)
        nearest = np.argmin(np.linalg.norm(points[:, None] - planned.positions_m, axis=2), axis=1)
        assert np.linalg.norm(points - planned.positions_m[nearest], axis=1).max() < 1e-6, "the tip on the seam"
        # The bottom plate is the table (base z up): at every kept pose the torch stands 10 deg steeper to it.
        np.testing.assert_allclose(degrees_below_horizontal(axes), below_deg[nearest] + 10.0, atol=0.1)
        means.append(axes.mean(axis=0) / np.linalg.norm(axes.mean(axis=0)))
    assert np.degrees(np.arccos(np.clip(means[0] @ means[1], -1, 1))) < 0.2, "the same physical tilt both ways"


def test_check_names_the_rule_each_seam_got_when_given_a_work_angle(path_file):
    result = run("check", path_file, "--robot-base", BASE, "--standoff-mm", "12", "--work-angle-deg", "5")
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == "seam 0: v_groove, work angle 5 deg toward the side away from the robot"
    plain = run("check", path_file, "--robot-base", BASE, "--standoff-mm", "12")
    assert "work angle" not in plain.stdout


def test_a_work_angle_on_a_csv_is_refused_naming_the_file_before_any_connection(tmp_path, path_file):
    from weldseam.io.paths import write_paths
    from weldseam.types import RunResult

    csv = tmp_path / "path.csv"
    write_paths(RunResult(paths=tuple(read_paths(path_file))), csv)
    message = (f"Error: {csv}: seam 0 names no joint kind (a CSV names none), and the side a work angle tilts to "
               "depends on it: give --joint (v_groove, bevel, square_butt, fillet, lap, outside_corner) or the "
               "plan's .json\n")  # fmt: skip
    for command, options in (("check", []), ("send", ["--host", "127.0.0.254", "--yes"])):
        result = run(command, str(csv), "--robot-base", BASE, "--work-angle-deg", "5", *options)
        # Exit 2, not 6: nothing is listening at 127.0.0.254, so no connection was tried.
        assert (result.returncode, result.stdout, result.stderr) == (2, "", message), command
    stated = run("check", str(csv), "--robot-base", BASE, "--standoff-mm", "12", "--work-angle-deg", "5", "--joint",
                 "v_groove", "--json")  # fmt: skip
    own = run("check", path_file, "--robot-base", BASE, "--standoff-mm", "12", "--work-angle-deg", "5", "--json")
    assert stated.returncode == own.returncode == 0, stated.stderr
    np.testing.assert_allclose(weld_torch_axes(json.loads(stated.stdout)), weld_torch_axes(json.loads(own.stdout)),
                               atol=1e-8)  # fmt: skip
    assert run("check", str(csv), "--robot-base", BASE, "--standoff-mm", "12").returncode == 0, "no angle, no kind needed"


@pytest.mark.parametrize(
    "joint, message",
    [("fillet", "every seam names its joint kind; --joint is for a path that names none (a CSV)"),
     ("tee", "--joint 'tee': choose one of v_groove, bevel, square_butt, fillet, lap, outside_corner")],
)  # fmt: skip
def test_a_joint_nothing_takes_is_refused(path_file, joint, message):
    result = run("check", path_file, "--robot-base", BASE, "--joint", joint)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.startswith("Error: ") and result.stderr.rstrip().endswith(message)
