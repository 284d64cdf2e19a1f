"""Batch planning as a library: finding scans and sidecars, naming outputs, resuming."""

import json
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import v_groove_cloud
from weldseam.batch import find_scans, make_jobs, run_batch, sidecars
from weldseam.config import PlanConfig, config_to_dict
from weldseam.errors import InputError
from weldseam.io.clouds import write_ply

PARAMS = config_to_dict(PlanConfig())


def touch(path, text="{}"):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def jobs_for(scans, out_dir, **changes):
    options = dict(params=PARAMS, fmt="json", rotation="rotvec", units="m", cloud_frame="base", allow_empty=False)
    return make_jobs(scans, out_dir, **{**options, **changes})


def test_folders_are_searched_recursively_for_scans_only(tmp_path):
    for name in ("a.ply", "deep/b.pcd", "deep/deeper/c.png", "d.npy"):
        touch(tmp_path / name)
    for name in ("c.intrinsics.json", "notes.md", "deep/.hidden.ply"):
        touch(tmp_path / name)
    found = find_scans([str(tmp_path)])
    assert [p.relative_to(tmp_path).as_posix() for p in found] == ["a.ply", "d.npy", "deep/b.pcd", "deep/deeper/c.png"]
    assert find_scans([str(tmp_path / "*.ply"), str(tmp_path / "a.ply")]) == [tmp_path / "a.ply"]


def test_a_missing_input_or_an_empty_glob_is_an_error(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        find_scans([str(tmp_path / "nope.ply")])
    with pytest.raises(InputError, match="matches nothing"):
        find_scans([str(tmp_path / "*.pcd")])


def test_sidecars_follow_the_documented_convention(tmp_path):
    scan = touch(tmp_path / "part.png")
    assert sidecars(scan) == (None, None)
    shared = touch(tmp_path / "d415.intrinsics.json")
    assert sidecars(scan) == (shared, None)  # the only *.intrinsics.json in the folder
    generic = touch(tmp_path / "intrinsics.json")
    pose = touch(tmp_path / "pose.json")
    assert sidecars(scan) == (generic, pose)
    own = touch(tmp_path / "part.intrinsics.json")
    own_pose = touch(tmp_path / "part.pose.json")
    assert sidecars(scan) == (own, own_pose)
    assert sidecars(touch(tmp_path / "cloud.ply")) == (None, pose)  # clouds need no intrinsics


def test_outputs_that_would_collide_keep_their_extension(tmp_path):
    scans = [touch(tmp_path / "x" / "part.ply"), touch(tmp_path / "y" / "part.ply"), touch(tmp_path / "part.pcd")]
    names = [job.output for job in jobs_for(sorted(scans), tmp_path / "out")]
    out = str(tmp_path / "out")
    assert sorted(names) == sorted({f"{out}/part.json", f"{out}/x/part.json", f"{out}/y/part.json"})


def test_a_changed_scan_sidecar_or_setting_changes_the_fingerprint(tmp_path):
    scan = touch(tmp_path / "part.ply", "one")
    first = jobs_for([scan], tmp_path)[0].fingerprint
    assert jobs_for([scan], tmp_path)[0].fingerprint == first
    assert jobs_for([scan], tmp_path, fmt="csv")[0].fingerprint != first
    touch(tmp_path / "part.pose.json", '{"T_base_camera": []}')
    with_pose = jobs_for([scan], tmp_path)[0].fingerprint
    assert with_pose != first
    scan.write_text("two")
    assert jobs_for([scan], tmp_path)[0].fingerprint != with_pose


def test_a_bad_scan_fails_alone_and_a_second_run_skips_what_is_done(tmp_path):
    good = tmp_path / "in" / "groove.ply"
    good.parent.mkdir()
    write_ply(good, v_groove_cloud(np.random.default_rng(1)))
    touch(
        good.with_name("groove.pose.json"),
        json.dumps({"T_base_camera": [[1, 0, 0, 0], [0, 1, 0, 0.05], [0, 0, 1, 0.45], [0, 0, 0, 1]]}),
    )
    touch(tmp_path / "in" / "broken.ply", "ply\nformat ascii 1.0\nelement vertex 5\n")
    out = tmp_path / "out"
    out.mkdir()
    jobs = jobs_for(find_scans([str(tmp_path / "in")]), out)
    first = {r.scan: r for r in run_batch(jobs, out, workers=1, scheduler=None, force=False)}
    assert first[str(good)].status == "ok" and first[str(good)].seams == 1
    assert first[str(tmp_path / "in" / "broken.ply")].status == "failed"
    assert "broken.ply" in first[str(tmp_path / "in" / "broken.ply")].error
    summary = json.loads((out / "summary.json").read_text())
    assert [row["status"] for row in summary] == ["failed", "ok"]
    written = (out / "groove.json").stat().st_mtime_ns
    second = {r.scan: r for r in run_batch(jobs, out, workers=1, scheduler=None, force=False)}
    assert second[str(good)].status == "skipped" and second[str(good)].seams == 1
    assert second[str(tmp_path / "in" / "broken.ply")].status == "failed"  # failures are retried
    assert (out / "groove.json").stat().st_mtime_ns == written
    forced = {r.scan: r for r in run_batch(jobs, out, workers=1, scheduler=None, force=True)}
    assert forced[str(good)].status == "ok"


def crash_on_second(job):
    """A stand-in for a scan that kills its worker (a segfault, the out-of-memory killer)."""
    import os

    from weldseam.batch import JobResult

    if job.scan.endswith("1.ply"):
        os._exit(9)
    return JobResult(job.scan, job.output, "ok", seams=1)


def test_a_worker_that_dies_fails_its_scan_only(tmp_path):
    from weldseam.batch import run_local

    scans = [touch(tmp_path / f"part{k}.ply") for k in range(4)]
    results = {Path(r.scan).name: r for r in run_local(jobs_for(scans, tmp_path / "out"), 2, work=crash_on_second)}
    assert {name: r.status for name, r in results.items()} == {
        "part0.ply": "ok", "part1.ply": "failed", "part2.ply": "ok", "part3.ply": "ok"
    }
    assert results["part1.ply"].error == "the worker process crashed on this scan (exit code 9)"


def killed_on_second(job):
    """A stand-in for the out-of-memory killer."""
    import os
    import signal

    from weldseam.batch import JobResult

    if job.scan.endswith("1.ply"):
        os.kill(os.getpid(), signal.SIGKILL)
    return JobResult(job.scan, job.output, "ok", seams=1)


def test_a_killed_worker_fails_its_scan_only_and_says_by_what(tmp_path):
    from weldseam.batch import run_local

    scans = [touch(tmp_path / f"part{k}.ply") for k in range(5)]
    results = {Path(r.scan).name: r for r in run_local(jobs_for(scans, tmp_path / "out"), 2, work=killed_on_second)}
    assert sorted(results) == [f"part{k}.ply" for k in range(5)]
    assert [name for name, r in results.items() if r.status != "ok"] == ["part1.ply"]
    assert results["part1.ply"].error == "the worker process was killed by SIGKILL on this scan"


def test_a_glob_takes_scans_and_leaves_their_sidecars(tmp_path):
    touch(tmp_path / "part.ply")
    touch(tmp_path / "part.pose.json")
    assert find_scans([str(tmp_path / "*")]) == [tmp_path / "part.ply"]


def test_an_output_whose_result_never_arrived_is_removed_so_the_summary_lists_every_output(tmp_path):
    # A worker that wrote its output just as a stop signal ended the run: its result is lost, so
    # its file goes too (a resume plans it again); an older file, and a reported one, stay.
    import os
    import time
    from types import SimpleNamespace

    from weldseam.batch import _drop_unreported

    reported, unreported, older = (tmp_path / f"{name}.json" for name in ("reported", "unreported", "older"))
    older.write_text("{}")
    os.utime(older, (time.time() - 60, time.time() - 60))
    started = time.time() - 1
    reported.write_text("{}")
    unreported.write_text("{}")
    jobs = [SimpleNamespace(output=str(path)) for path in (reported, unreported, older)]
    _drop_unreported(jobs, [SimpleNamespace(output=str(reported))], started)
    assert reported.exists() and not unreported.exists() and older.exists()


def interrupt_swallowed_on_first(job):
    """A Ctrl-C whose exception is lost where it is raised, as Python does in an at-fork hook."""
    import os
    import signal

    from weldseam.batch import JobResult

    if job.scan.endswith("0.ply"):
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            pass
    return JobResult(job.scan, job.output, "ok", seams=1)


def test_a_stop_signal_whose_exception_was_swallowed_still_stops_the_batch_in_this_process(tmp_path):
    from weldseam.batch import run_local
    from weldseam.batch_workers import Interrupted, StopSignals

    scans = [touch(tmp_path / f"part{k}.ply") for k in range(3)]
    finished = []
    with StopSignals() as stop, pytest.raises(Interrupted) as interrupt:
        for result in run_local(jobs_for(scans, tmp_path / "out"), 1, work=interrupt_swallowed_on_first, stop=stop):
            finished.append(Path(result.scan).name)
    assert interrupt.value.signum == 2 and finished == ["part0.ply"]
