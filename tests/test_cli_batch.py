"""`weldseam batch` run as a user would: a folder with a corrupt scan, resume, dask, Ctrl-C."""

import csv
import os
import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "samples"


def weldseam(*args, **options):
    return subprocess.run(
        [sys.executable, "-m", "weldseam.cli", *map(str, args)], capture_output=True, timeout=300, **options
    )


@pytest.fixture(scope="module")
def captures(tmp_path_factory):
    """The two samples with their sidecars, named by the batch convention, plus a corrupt scan."""
    folder = tmp_path_factory.mktemp("captures")
    shutil.copy(SAMPLES / "v_butt.ply", folder / "v_butt.ply")
    shutil.copy(SAMPLES / "v_butt.pose.json", folder / "v_butt.pose.json")
    (folder / "cell").mkdir()
    shutil.copy(SAMPLES / "fillet_t.png", folder / "cell" / "fillet_t.png")
    shutil.copy(SAMPLES / "fillet_t.pose.json", folder / "cell" / "fillet_t.pose.json")
    shutil.copy(SAMPLES / "d415.intrinsics.json", folder / "cell" / "intrinsics.json")
    (folder / "cell" / "broken.ply").write_bytes((SAMPLES / "v_butt.ply").read_bytes()[:2000])
    return folder


@pytest.fixture(scope="module")
def planned(captures, tmp_path_factory):
    out = tmp_path_factory.mktemp("out")
    result = weldseam("batch", captures, "-o", out, "--format", "csv", "--jobs", "2")
    return result, out


def summary_rows(out: Path) -> dict[str, dict]:
    with open(out / "summary.csv", newline="") as file:
        return {Path(row["scan"]).name: row for row in csv.DictReader(file)}


def test_a_corrupt_scan_fails_alone_and_the_exit_code_says_so(planned):
    result, out = planned
    assert result.returncode == 1
    rows = summary_rows(out)
    assert {name: row["status"] for name, row in rows.items()} == {
        "v_butt.ply": "ok",
        "fillet_t.png": "ok",
        "broken.ply": "failed",
    }
    assert "truncated PLY" in rows["broken.ply"]["error"]
    assert rows["v_butt.ply"]["seams"] == "1" and float(rows["v_butt.ply"]["length_m"]) > 0.15
    assert result.stderr.decode().strip().splitlines()[-1].startswith("3 scan(s): 2 planned, 0 up to date, 1 failed")
    assert result.stdout == b""
    assert not list(out.rglob("*.tmp")) and not (out / "cell" / "broken.csv").exists()


def test_batch_outputs_are_byte_identical_to_plan(planned, captures, tmp_path):
    _, out = planned
    single = tmp_path / "single.csv"
    plan = weldseam(
        "plan",
        captures / "cell" / "fillet_t.png",
        "--intrinsics",
        captures / "cell" / "intrinsics.json",
        "--camera-pose",
        captures / "cell" / "fillet_t.pose.json",
        "-o",
        single,
        "-q",
    )
    assert plan.returncode == 0, plan.stderr
    assert (out / "cell" / "fillet_t.csv").read_bytes() == single.read_bytes()


def test_batch_json_equals_plan_json_but_for_the_wall_clock_timings(captures, tmp_path):
    scan, pose = captures / "v_butt.ply", captures / "v_butt.pose.json"
    assert weldseam("batch", scan, "-o", tmp_path / "out", "-q").returncode == 0
    assert weldseam("plan", scan, "--camera-pose", pose, "-o", tmp_path / "single.json", "-q").returncode == 0
    batched = json.loads((tmp_path / "out" / "v_butt.json").read_text())
    single = json.loads((tmp_path / "single.json").read_text())
    assert batched.pop("timings_s").keys() == single.pop("timings_s").keys()
    assert batched == single and batched["input"]["path"] == str(scan)


def test_a_second_run_skips_up_to_date_outputs_and_force_redoes_them(planned, captures):
    _, out = planned
    again = weldseam("batch", captures, "-o", out, "--format", "csv", "--jobs", "1")
    assert again.returncode == 1
    assert "3 scan(s): 0 planned, 2 up to date, 1 failed" in again.stderr.decode()
    only_good = weldseam("batch", captures / "v_butt.ply", "-o", out, "--format", "csv", "--force")
    assert only_good.returncode == 0
    assert "1 scan(s): 1 planned, 0 up to date, 0 failed" in only_good.stderr.decode()


def test_the_same_batch_on_a_dask_cluster_gives_the_same_outputs(captures, tmp_path):
    distributed = pytest.importorskip("distributed")
    good = tmp_path / "good"
    shutil.copytree(captures, good)
    (good / "cell" / "broken.ply").unlink()
    local = tmp_path / "local"
    assert weldseam("batch", good, "-o", local, "--format", "csv", "--jobs", "1").returncode == 0
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        remote = tmp_path / "remote"
        result = weldseam("batch", good, "-o", remote, "--format", "csv", "--scheduler", cluster.scheduler_address)
    assert result.returncode == 0, result.stderr
    for name in ("v_butt.csv", "cell/fillet_t.csv"):
        assert (remote / name).read_bytes() == (local / name).read_bytes()


def test_ctrl_c_stops_the_batch_and_leaves_no_half_written_file(captures, tmp_path):
    many = tmp_path / "many"
    many.mkdir()
    for k in range(6):
        shutil.copy(SAMPLES / "v_butt.ply", many / f"part{k}.ply")
        shutil.copy(SAMPLES / "v_butt.pose.json", many / f"part{k}.pose.json")
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "weldseam.cli", "batch", str(many), "-o", str(out), "--jobs", "1"],
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    first_line = process.stderr.readline()  # the first scan is done
    assert first_line.startswith(b"[1/6] ok")
    time.sleep(0.3)
    process.send_signal(signal.SIGINT)
    _, rest = process.communicate(timeout=120)
    assert process.returncode == 130, rest
    assert b"Error: interrupted" in rest
    assert not list(out.glob(".*.tmp"))
    rows = summary_rows(out)
    assert 1 <= len(rows) < 6 and all(row["status"] == "ok" for row in rows.values())
    assert all((out / f"{Path(name).stem}.json").is_file() for name in rows)


def test_robot_state_sidecars_with_a_hand_eye_file_plan_like_camera_poses(tmp_path):
    """fillet_t.png placed by its T_base_camera sidecar, or by a flange pose sidecar and --hand-eye: same path."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from weldseam.io.paths import read_paths

    T_base_camera = np.array(json.loads((SAMPLES / "fillet_t.pose.json").read_text())["T_base_camera"])
    T_flange_camera = np.eye(4)
    T_flange_camera[:3, :3] = Rotation.from_euler("xyz", [1.0, -2.0, 90.0], degrees=True).as_matrix()
    T_flange_camera[:3, 3] = [0.03, -0.06, 0.05]
    flange = T_base_camera @ np.linalg.inv(T_flange_camera)
    folders = {}
    for name, pose in (("camera", {"T_base_camera": T_base_camera.tolist()}),
                       ("robot", {"flange_pose": [*flange[:3, 3], *Rotation.from_matrix(flange[:3, :3]).as_rotvec()]})):
        folder = folders[name] = tmp_path / name
        folder.mkdir()
        shutil.copy(SAMPLES / "fillet_t.png", folder / "fillet_t.png")
        shutil.copy(SAMPLES / "d415.intrinsics.json", folder / "intrinsics.json")
        (folder / "fillet_t.pose.json").write_text(json.dumps(pose))
    hand_eye = tmp_path / "H.json"
    hand_eye.write_text(json.dumps({"setup": "eye-in-hand", "T_flange_camera": T_flange_camera.tolist()}))
    assert weldseam("batch", folders["camera"], "-o", tmp_path / "out_camera", "-q").returncode == 0
    missing = weldseam("batch", folders["robot"], "-o", tmp_path / "out_missing", "-q")
    assert missing.returncode == 1 and b"--hand-eye" in (tmp_path / "out_missing" / "summary.csv").read_bytes()
    placed = weldseam("batch", folders["robot"], "-o", tmp_path / "out_robot", "--hand-eye", hand_eye, "-q")
    assert placed.returncode == 0, placed.stderr.decode()
    ours, theirs = (read_paths(tmp_path / out / "fillet_t.json") for out in ("out_robot", "out_camera"))
    assert len(ours) == len(theirs) >= 1
    for a, b in zip(ours, theirs, strict=True):
        assert np.allclose(a.positions_m, b.positions_m, atol=1e-6)


def test_a_bad_hand_eye_file_stops_the_batch_before_any_scan(captures, tmp_path):
    bad = tmp_path / "H.json"
    bad.write_text(json.dumps({"setup": "eye-in-hand"}))
    result = weldseam("batch", captures, "-o", tmp_path / "out", "--hand-eye", bad)
    assert result.returncode == 2
    assert result.stderr.decode().strip() == f'Error: {bad}: an eye-in-hand file needs "T_flange_camera" (a 4x4 matrix)'
    assert not (tmp_path / "out" / "summary.csv").exists()


@pytest.fixture
def eight_scans(tmp_path):
    many = tmp_path / "many"
    many.mkdir()
    for k in range(8):
        shutil.copy(SAMPLES / "v_butt.ply", many / f"part{k}.ply")
        shutil.copy(SAMPLES / "v_butt.pose.json", many / f"part{k}.pose.json")
    return many


def processes_in_session(session: int) -> list[str]:
    """The processes left in a session, after giving the dying ones up to 10 s."""
    for _ in range(100):
        left = subprocess.run(["pgrep", "-s", str(session)], capture_output=True, text=True).stdout.split()
        if not left:
            return []
        time.sleep(0.1)
    return left


def start_batch(scans: Path, out: Path, jobs: int) -> subprocess.Popen:
    """A batch in its own session (a supervisor's child), once its first scan is done."""
    process = subprocess.Popen(
        [sys.executable, "-m", "weldseam.cli", "batch", str(scans), "-o", str(out), "--jobs", str(jobs)],
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    assert process.stderr.readline().startswith(b"[1/8] ok")
    return process


@pytest.mark.skipif(shutil.which("pgrep") is None, reason="needs pgrep to see the processes left")
@pytest.mark.parametrize("to_group", [False, True], ids=["main-process", "process-group"])
@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_a_stop_signal_ends_the_batch_and_its_workers_and_keeps_what_finished(
    eight_scans, tmp_path, signum, code, to_group
):
    out = tmp_path / "out"
    process = start_batch(eight_scans, out, jobs=2)
    (os.killpg if to_group else os.kill)(process.pid, signum)
    _, rest = process.communicate(timeout=60)  # the old batch never exited after a SIGINT to it alone
    assert process.returncode == code, rest.decode()
    assert rest.decode().strip().splitlines()[-1].startswith(f"Error: interrupted by {signum.name}: ")
    assert processes_in_session(process.pid) == []  # no orphaned worker goes on planning
    written = sorted(path.name for path in out.glob("part*.json"))
    rows = summary_rows(out)
    assert 1 <= len(rows) < 8 and all(row["status"] == "ok" for row in rows.values())
    assert sorted(f"{Path(name).stem}.json" for name in rows) == written  # every finished output, and only those
    assert not [path for path in out.iterdir() if path.name.endswith(".tmp")]


@pytest.mark.skipif(shutil.which("pgrep") is None, reason="needs pgrep to see the processes left")
def test_a_sigterm_to_a_one_process_batch_stops_its_helper_process_silently(eight_scans, tmp_path):
    out = tmp_path / "out"
    process = start_batch(eight_scans, out, jobs=1)
    os.killpg(process.pid, signal.SIGTERM)
    _, rest = process.communicate(timeout=60)
    assert process.returncode == 143
    assert rest.decode().strip().splitlines()[-1].startswith("Error: interrupted by SIGTERM: ")
    assert "Traceback" not in rest.decode()
    assert processes_in_session(process.pid) == []
    assert all(row["status"] == "ok" for row in summary_rows(out).values())


@pytest.mark.skipif(shutil.which("pgrep") is None, reason="needs pgrep to see the processes left")
def test_workers_die_with_a_killed_main_process(eight_scans, tmp_path):
    """SIGKILL (the out-of-memory killer) cannot be caught: the kernel stops the workers."""
    process = start_batch(eight_scans, tmp_path / "out", jobs=2)
    process.kill()
    process.wait(timeout=60)
    assert processes_in_session(process.pid) == []


def test_the_summary_lists_every_warning_of_each_scan_as_plan_prints_them(tmp_path):
    scans = tmp_path / "scans"
    scans.mkdir()
    shutil.copy(SAMPLES / "v_butt.ply", scans / "v_butt.ply")  # no pose: the normals' guess is a warning
    shutil.copy(SAMPLES / "fillet_t.png", scans / "fillet_t.png")  # no pose: the camera frame is a warning
    shutil.copy(SAMPLES / "d415.intrinsics.json", scans / "intrinsics.json")
    printed = {}
    for name, extra in (("v_butt.ply", []), ("fillet_t.png", ["--intrinsics", scans / "intrinsics.json"])):
        plan = weldseam("plan", scans / name, *extra, "-o", tmp_path / f"{name}.json")
        assert plan.returncode == 0, plan.stderr
        lines = plan.stderr.decode().splitlines()
        printed[name] = [line.removeprefix("Warning: ") for line in lines if line.startswith("Warning: ")]
        assert printed[name]
    out = tmp_path / "out"
    for run in range(2):  # the second run skips both scans and keeps their warnings
        assert weldseam("batch", scans, "-o", out, "-q").returncode == 0
        listed = {Path(row["scan"]).name: row["warnings"] for row in json.loads((out / "summary.json").read_text())}
        assert listed == printed
        assert {name: row["warnings"] for name, row in summary_rows(out).items()} == {
            name: " | ".join(warnings) for name, warnings in printed.items()
        }
    assert {row["status"] for row in summary_rows(out).values()} == {"skipped"}


@pytest.mark.parametrize(
    ("folder", "problem"),
    [
        ("{file}/out", "cannot create the folder (Not a directory)"),
        ("{file}", "is a file, not a folder"),
        ("{unwritable}", "cannot write in {unwritable} (Permission denied)"),
    ],
)
def test_an_output_folder_that_cannot_be_written_is_one_line_before_any_scan(tmp_path, folder, problem):
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    if os.geteuid() == 0:  # root writes in any folder of its own; sysfs refuses it
        unwritable = Path("/sys")
    else:
        unwritable = tmp_path / "locked"
        unwritable.mkdir(mode=0o500)
    out = folder.format(file=a_file, unwritable=unwritable)
    result = weldseam("batch", SAMPLES / "v_butt.ply", "-o", out)
    assert result.returncode == 2
    assert result.stderr.decode() == f"Error: {out}: {problem.format(unwritable=unwritable)}\n"  # nothing planned, no traceback
