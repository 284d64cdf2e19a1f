"""`weldseam batch`: plan every scan of folders, files or globs into one output each."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from weldseam.commands.common import command_overrides, reported, stderr

EPILOG = (
    "Example:\n\n"
    "  weldseam batch captures/ -o paths/\n\n"
    "  weldseam batch 'cell3/**/*.png' extra.ply -o paths/ --format csv --jobs 2 --config cell3.toml\n\n"
    "  weldseam batch captures/ -o paths/ --scheduler tcp://10.0.0.5:8786\n\n"
    "Sidecars, next to each scan: NAME.intrinsics.json, else intrinsics.json, else the only\n"
    "*.intrinsics.json in the folder (depth images); NAME.pose.json, else pose.json (optional):\n"
    '{"T_base_camera": 4x4}, or the robot state {"flange_pose": [...]} / {"joints_rad": [...]} with --hand-eye.\n'
    "Outputs: OUTDIR/NAME.json (or .csv), OUTDIR/summary.csv and summary.json (one row per scan,\n"
    "with its status, error and warnings). Scans whose\n"
    "output is up to date (same scan, sidecars and settings) are skipped unless --force.\n\n"
    "Exit codes:\n\n"
    "0: every scan planned\n\n"
    "1: some scans failed or had no seam (see the summary; the others are done)\n\n"
    "2: usage error, unreadable input list / config, or an output folder that cannot be\n"
    "written (said before any scan is planned)\n\n"
    "129, 130, 143: stopped by SIGHUP, SIGINT (Ctrl-C) or SIGTERM, sent to this process or its\n"
    "whole group: the workers stop within seconds, the outputs finished so far and the summary\n"
    "are kept, no process is left"
)


def batch(
    inputs: Annotated[list[str], typer.Argument(help="Scan files, folders (searched recursively) or glob patterns.")],
    out_dir: Annotated[Path, typer.Option("--output", "-o", help="Folder for the outputs and the summary.")],
    jobs: Annotated[Optional[int], typer.Option("--jobs", "-j", help="Local worker processes (default: cores).")] = (
        None
    ),
    force: Annotated[bool, typer.Option(help="Plan every scan again, even when its output is up to date.")] = False,
    fmt: Annotated[Optional[str], typer.Option("--format", help="json (default) or csv.")] = None,
    rotation: Annotated[Optional[str], typer.Option(help="CSV rotation columns: rotvec (default) or quat.")] = None,
    units: Annotated[str, typer.Option(help="Units of cloud files: m or mm.")] = "m",
    cloud_frame: Annotated[str, typer.Option(help="Frame of cloud files: base or camera.")] = "base",
    config_file: Annotated[
        Optional[str], typer.Option("--config", help="TOML config file (see `weldseam config show`).")
    ] = None,
    settings: Annotated[
        Optional[list[str]], typer.Option("--set", help="Override a parameter: section.key=value (repeatable).")
    ] = None,
    allow_empty: Annotated[bool, typer.Option(help="A scan with no seam gets an empty path and counts as ok.")] = False,
    hand_eye: Annotated[
        Optional[Path], typer.Option(help="Hand-eye file: places scans whose pose sidecar gives the robot state.")
    ] = None,
    scheduler: Annotated[
        Optional[str], typer.Option(help="Run on a dask.distributed cluster at this address (tcp://HOST:PORT).")
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Only the final line and errors on stderr.")] = False,
) -> None:
    """Plan many scans: one path file per scan, a summary, failures never stop the others."""
    with reported():
        from weldseam.batch import find_scans, make_jobs, run_batch
        from weldseam.batch_workers import Interrupted, StopSignals
        from weldseam.config import config_to_dict, effective_config
        from weldseam.errors import InputError
        from weldseam.io.atomic import prepare_folder
        from weldseam.io.hand_eye import read_hand_eye

        if hand_eye is not None:
            read_hand_eye(hand_eye)  # a bad file stops the batch before any scan
        overrides = command_overrides(settings, fmt, rotation)
        config = effective_config(config_file, overrides)
        workers = jobs if jobs is not None else (os.cpu_count() or 1)
        if workers < 1:
            raise InputError(f"--jobs must be at least 1, got {workers}")
        scans = find_scans(inputs)
        if not scans:
            raise InputError(f"no scans (.ply .pcd .xyz .txt .npy .png) in {' '.join(inputs)}")
        prepare_folder(out_dir)
        output_format = "json" if config.output.format == "auto" else config.output.format
        work = make_jobs(
            scans,
            out_dir,
            params=config_to_dict(config),
            fmt=output_format,
            rotation=config.output.rotation,
            units=units,
            cloud_frame=cloud_frame,
            allow_empty=allow_empty,
            hand_eye=hand_eye,
        )
        progress = _reporter(len(work), quiet)
        try:
            with StopSignals() as stop, progress:
                results = run_batch(
                    work, out_dir, workers=workers, scheduler=scheduler, force=force, on_result=progress, stop=stop
                )
        except Interrupted as interrupt:
            stderr(
                f"Error: interrupted by {interrupt}: {progress.done} of {len(work)} scan(s) finished; "
                f"their outputs and {out_dir / 'summary.csv'} are kept"
            )
            raise typer.Exit(128 + interrupt.signum) from None  # the shell's rule, as listed in EXIT_CODES
        failed = sum(result.failed for result in results)
        skipped = sum(result.status == "skipped" for result in results)
        stderr(
            f"{len(results)} scan(s): {len(results) - failed - skipped} planned, {skipped} up to date, "
            f"{failed} failed -> {out_dir / 'summary.csv'}"
        )
        if failed:
            raise typer.Exit(1)


class _reporter:
    """A rich progress bar on a terminal; one plain line per finished scan otherwise."""

    def __init__(self, total: int, quiet: bool):
        self.total, self.quiet, self.done, self.progress = total, quiet, 0, None

    def __enter__(self):
        if not self.quiet and sys.stderr.isatty():
            from rich.console import Console
            from rich.progress import Progress

            self.progress = Progress(console=Console(stderr=True))
            self.progress.start()
            self.task = self.progress.add_task("planning", total=self.total)
        return self

    def __call__(self, result) -> None:
        self.done += 1
        if result.status == "ok":
            detail = f"{result.seams} seam(s), {result.length_m * 1000:.1f} mm, {result.seconds:.2f} s"
        elif result.status == "skipped":
            detail = "up to date"
        else:
            detail = result.error.removeprefix(f"{result.scan}: ")
        line = f"{result.status:<8} {result.scan}: {detail}"
        if self.progress is not None:
            self.progress.console.print(line, markup=False, highlight=False)
            self.progress.advance(self.task)
        elif not self.quiet:
            stderr(f"[{self.done}/{self.total}] {line}")

    def __exit__(self, *exc) -> None:
        if self.progress is not None:
            self.progress.stop()
