"""Batch planning: many scans, one output each, a summary, local processes or a dask cluster.

Inputs are files, folders (searched recursively for scans) or glob patterns. Sidecar files
are found by convention, next to the scan:
- intrinsics (depth images): `NAME.intrinsics.json`, else `intrinsics.json`, else the only
  `*.intrinsics.json` in the folder;
- camera pose (optional): `NAME.pose.json`, else `pose.json`.
Each scan `DIR/NAME.EXT` is written to `OUTDIR/SUB/NAME.json` (or `.csv`), SUB being DIR
relative to the folder all scans share, so the outputs mirror the inputs; when two scans in
one folder share a name, the ones after the first keep their extension (`NAME.EXT.json`). A scan whose output
exists and was made from the same bytes (scan and sidecars) with the same settings is skipped
(the record is `OUTDIR/.weldseam-batch.json`), so an interrupted batch resumes where it stopped.
SIGINT, SIGTERM or SIGHUP stop a batch within seconds, keeping what finished (batch_workers.py).
"""

from __future__ import annotations

import glob
import hashlib
import json
import os
import time
from collections.abc import Callable, Iterator
from contextlib import closing
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from weldseam.batch_workers import StopSignals, WorkerDied, run_in_processes
from weldseam.errors import InputError, NoSeamError, WeldseamError
from weldseam.io.atomic import atomic_write
from weldseam.io.sidecars import sidecars

SCAN_SUFFIXES = (".ply", ".pcd", ".xyz", ".txt", ".npy", ".png")
STATE_FILE = ".weldseam-batch.json"
SUMMARY_FIELDS = ("scan", "output", "status", "seams", "length_m", "seconds", "error", "warnings")
# Between the warnings of one scan in summary.csv (summary.json has a list).
WARNING_SEPARATOR = " | "


@dataclass(frozen=True)
class BatchJob:
    """Everything one worker needs to plan one scan (plain data, so it pickles)."""

    scan: str
    scan_file: str
    output: str
    intrinsics: str | None
    camera_pose: str | None
    fingerprint: str
    params: dict
    fmt: str
    rotation: str
    units: str = "m"
    cloud_frame: str = "base"
    allow_empty: bool = False
    hand_eye: str | None = None


@dataclass(frozen=True)
class JobResult:
    """One line of the summary. status: ok, no-seam, failed or skipped. warnings: every warning of
    the scan's run (reading it and planning it), as `plan` prints them."""

    scan: str
    output: str
    status: str
    seams: int = 0
    length_m: float = 0.0
    seconds: float = 0.0
    error: str = ""
    warnings: tuple[str, ...] = ()

    @property
    def failed(self) -> bool:
        return self.status in ("failed", "no-seam")


def find_scans(inputs: list[str]) -> list[Path]:
    """Scan files named by `inputs` (files, folders searched recursively, globs), sorted, each once."""
    found: set[Path] = set()
    for item in inputs:
        if glob.has_magic(item):
            matches = [Path(path) for path in sorted(glob.glob(item, recursive=True))]
            if not matches:
                raise InputError(f"{item}: matches nothing")
        else:
            matches = [Path(item)]
            if not matches[0].exists():
                raise InputError(f"{item}: no such file or folder")
        for path in matches:
            if path.is_dir():
                found.update(p for p in path.rglob("*") if p.is_file() and _is_scan(p))
            elif path.is_file() and (not glob.has_magic(item) or _is_scan(path)):
                found.add(path)
    return sorted(found)


def _is_scan(path: Path) -> bool:
    return path.suffix.lower() in SCAN_SUFFIXES and not path.name.startswith(".")


def make_jobs(
    scans: list[Path],
    out_dir: Path,
    *,
    params: dict,
    fmt: str,
    rotation: str,
    units: str,
    cloud_frame: str,
    allow_empty: bool,
    hand_eye: Path | None = None,
) -> list[BatchJob]:
    """One job per scan, with its output name and a fingerprint of everything that makes its output
    (the scan, its sidecars, the hand-eye file and the settings)."""
    taken: set[Path] = set()
    jobs = []
    settings = json.dumps([params, fmt, rotation, units, cloud_frame, allow_empty], sort_keys=True)
    root = Path(os.path.commonpath([scan.resolve().parent for scan in scans])) if scans else Path()
    for scan in scans:
        folder = out_dir / scan.resolve().parent.relative_to(root)
        name = folder / f"{scan.stem}.{fmt}"
        if name in taken:
            name = folder / f"{scan.name}.{fmt}"
        taken.add(name)
        intrinsics, pose = sidecars(scan)
        digest = hashlib.sha256(settings.encode())
        for part in (scan, intrinsics, pose, hand_eye):
            digest.update(b"\0" if part is None else _file_digest(part))
        jobs.append(
            BatchJob(
                scan=str(scan),
                scan_file=str(scan.resolve()),
                output=str(name.resolve()),
                intrinsics=None if intrinsics is None else str(intrinsics.resolve()),
                camera_pose=None if pose is None else str(pose.resolve()),
                fingerprint=digest.hexdigest(),
                params=params,
                fmt=fmt,
                rotation=rotation,
                units=units,
                cloud_frame=cloud_frame,
                allow_empty=allow_empty,
                hand_eye=None if hand_eye is None else str(hand_eye.resolve()),
            )
        )
    return jobs


def _file_digest(path: Path) -> bytes:
    try:
        return hashlib.sha256(path.read_bytes()).digest()
    except OSError:
        return b"unreadable"


def run_job(job: BatchJob) -> JobResult:
    """Plan one scan into its output file (atomically); failures become a result, never an exception."""
    started = time.perf_counter()
    try:
        from weldseam.config import PlanConfig, with_overrides
        from weldseam.io.paths import write_paths
        from weldseam.io.placement import PlacementOptions, place_scans, with_placement
        from weldseam.pipeline.run import plan_paths

        placed = place_scans(PlacementOptions(
            (job.scan_file,), intrinsics=job.intrinsics, camera_pose=job.camera_pose, hand_eye=job.hand_eye,
            cloud_frame=job.cloud_frame, units=job.units,
        ))
        scan = replace(placed.frames[0], source=job.scan)  # recorded and reported as the user named it
        result = plan_paths(scan, with_overrides(PlanConfig(), job.params), allow_empty=job.allow_empty)
        result = with_placement(result, placed)  # the frame, the placement and its warnings, as plan records them
        Path(job.output).parent.mkdir(parents=True, exist_ok=True)
        write_paths(result, job.output, fmt=job.fmt, rotation=job.rotation)
        return JobResult(
            job.scan,
            job.output,
            "ok",
            len(result.paths),
            round(sum(p.length_m for p in result.paths), 6),
            round(time.perf_counter() - started, 3),
            warnings=tuple(dict.fromkeys(result.warnings)),
        )
    except NoSeamError as error:
        status, message = "no-seam", str(error)
    except WeldseamError as error:
        status, message = "failed", str(error)
    except Exception as error:  # a bug on one scan must not stop the others
        status, message = "failed", f"internal error: {type(error).__name__}: {error}"
    return JobResult(job.scan, job.output, status, seconds=round(time.perf_counter() - started, 3), error=message)


def up_to_date(jobs: list[BatchJob], out_dir: Path) -> dict[str, JobResult]:
    """Skipped results for the outputs whose existing file was made from the same fingerprint."""
    try:
        state = json.loads((out_dir / STATE_FILE).read_text())
    except (OSError, ValueError):
        return {}
    skipped = {}
    for job in jobs:
        record = state.get(os.path.relpath(job.output, out_dir))
        if isinstance(record, dict) and record.get("fingerprint") == job.fingerprint and Path(job.output).is_file():
            seams, length = record.get("seams", 0), record.get("length_m", 0.0)
            warnings = tuple(record.get("warnings", ()))
            skipped[job.output] = JobResult(job.scan, job.output, "skipped", seams, length, warnings=warnings)
    return skipped


def save_state(jobs: list[BatchJob], results: list[JobResult], out_dir: Path) -> None:
    """Record the fingerprints of the outputs written successfully (merged with earlier runs)."""
    path = out_dir / STATE_FILE
    try:
        state = json.loads(path.read_text())
    except (OSError, ValueError):
        state = {}
    good = {result.output: result for result in results if result.status in ("ok", "skipped")}
    for job in jobs:
        if job.output in good:
            result = good[job.output]
            state[os.path.relpath(job.output, out_dir)] = {
                "fingerprint": job.fingerprint,
                "seams": result.seams,
                "length_m": result.length_m,
                "warnings": list(result.warnings),
            }
    atomic_write(path, (json.dumps(state, indent=1, sort_keys=True) + "\n").encode())


def run_local(
    jobs: list[BatchJob],
    workers: int,
    work: Callable[[BatchJob], JobResult] = run_job,
    stop: StopSignals | None = None,
) -> Iterator[JobResult]:
    """Results in completion order, from `workers` processes (in this process when 1).

    A worker that dies (a crash, the out-of-memory killer) fails its own scan only; the others
    go on in a new worker. A stop signal (`stop`) ends the workers within seconds
    (batch_workers.py) and raises Interrupted.
    """
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            yield work(job)
            if stop is not None:
                stop.raise_if_caught()
        return
    for job, result in run_in_processes(work, jobs, min(workers, len(jobs)), stop):
        if isinstance(result, WorkerDied):
            result = JobResult(job.scan, job.output, "failed", error=str(result))
        yield result


def run_dask(jobs: list[BatchJob], scheduler: str) -> Iterator[JobResult]:
    """Results in completion order from an existing dask.distributed cluster at `scheduler`."""
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise InputError("--scheduler needs dask.distributed: pip install 'weldseam[dask]'") from None
    try:
        client = Client(scheduler, timeout=10)
    except (OSError, TimeoutError) as error:
        raise InputError(f"--scheduler {scheduler}: cannot connect ({error})") from None
    try:
        futures = client.map(run_job, jobs, pure=False)
        try:
            for future in as_completed(futures):
                yield future.result()
        finally:
            client.cancel(futures)  # after an interrupt, what has not started never starts
    finally:
        client.close()


def write_summary(results: list[JobResult], out_dir: Path) -> None:
    """summary.json and summary.csv in OUTDIR, rows in scan order (in the CSV, a scan's warnings
    are joined by WARNING_SEPARATOR)."""
    rows = sorted((asdict(result) for result in results), key=lambda row: row["scan"])
    atomic_write(out_dir / "summary.json", (json.dumps(rows, indent=2) + "\n").encode())
    lines = [",".join(SUMMARY_FIELDS)]
    for row in rows:
        cells = {**row, "warnings": WARNING_SEPARATOR.join(row["warnings"])}
        lines.append(",".join(_csv_cell(cells[name]) for name in SUMMARY_FIELDS))
    atomic_write(out_dir / "summary.csv", ("\n".join(lines) + "\n").encode())


def _csv_cell(value) -> str:
    text = str(value)
    return '"' + text.replace('"', '""') + '"' if any(c in text for c in ',"\n') else text


def run_batch(
    jobs: list[BatchJob],
    out_dir: Path,
    *,
    workers: int,
    scheduler: str | None,
    force: bool,
    on_result: Callable[[JobResult], None] = lambda result: None,
    stop: StopSignals | None = None,
) -> list[JobResult]:
    """Run the jobs not already up to date, report each result as it completes, and write the
    summary and the resume record (also when interrupted: then for what finished). With `stop`
    open, a stop signal ends the run (Interrupted) after the workers have stopped."""
    current = {} if force else up_to_date(jobs, out_dir)
    results = list(current.values())
    for result in results:
        on_result(result)
    pending = [job for job in jobs if job.output not in current]
    started = time.time()
    try:
        stream = run_dask(pending, scheduler) if scheduler else run_local(pending, workers, stop=stop)
        with closing(stream):  # an error here stops the workers now, not when the generator is collected
            for result in stream:
                results.append(result)
                on_result(result)
    finally:
        _drop_unreported(pending, results, started)
        write_summary(results, out_dir)
        save_state(jobs, results, out_dir)
    return results


def _drop_unreported(pending: list[BatchJob], results: list[JobResult], started: float) -> None:
    """Remove the outputs this run wrote whose result never arrived (a worker that finished just as
    a stop signal ended the run): the summary lists every output, and only those; a resume plans
    those scans again."""
    reported = {result.output for result in results}
    for job in pending:
        path = Path(job.output)
        if job.output not in reported and path.exists() and path.stat().st_mtime >= started:
            path.unlink()
