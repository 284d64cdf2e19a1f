"""Time every pipeline stage and measure peak memory on D415-sized frames (640 x 480).

Each scan is rendered once (fixed seed) and saved as .npy; then, in a fresh process per scan,
`plan_paths` runs `--repeat` times (per-stage and total times, peak memory of that process);
finally the `weldseam plan` command runs once on the same file, timed as a user feels it
(wall time of the whole process, imports included).

Example:
    .venv/bin/python benchmarks/speed.py --scans v_butt,fillet_t --repeat 5
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

from common import format_table

# Nothing heavy is imported here: Linux carries a process's peak memory (ru_maxrss) across
# fork and exec, so every child would report at least this process's peak. Rendering and
# planning therefore run in children, and this process stays small.

SCANS = ("v_butt", "curved_groove", "fillet_t", "two_grooves")
SEED = 0
TARGET_S = 1.0
TARGET_MB = 1024.0
SCRIPT = os.path.abspath(__file__)
WELDSEAM = os.path.join(os.path.dirname(sys.executable), "weldseam")


def render(names: list[str], folder: str) -> dict[str, list[float]]:
    """Render each family with SEED into `folder`/NAME.npy; return each camera origin (m)."""
    import numpy as np

    from weldseam.synthetic.scenes import FAMILIES, make_scan

    unknown = sorted(set(names) - set(FAMILIES))
    if unknown:
        sys.exit(f"speed.py: unknown scene families {unknown}; known: {', '.join(FAMILIES)}")
    origins = {}
    for name in names:
        rng = np.random.default_rng(SEED)
        scan = make_scan(FAMILIES[name](rng), rng)
        np.save(os.path.join(folder, f"{name}.npy"), scan.points_m)
        origins[name] = scan.camera_origin_m.tolist()
    return origins


def time_plan(npy_path: str, camera_origin: str, repeat: int) -> dict:
    """Run plan_paths `repeat` times on one .npy scan: point count and, per run, the total
    wall time (s) and each stage's time (s, in pipeline order)."""
    import numpy as np

    from weldseam.config import PlanConfig
    from weldseam.pipeline.run import plan_paths
    from weldseam.types import Scan

    origin = np.array([float(v) for v in camera_origin.split(",")])
    scan = Scan(points_m=np.load(npy_path), camera_origin_m=origin, source=npy_path)
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = plan_paths(scan, PlanConfig(), allow_empty=True)
        runs.append({
            "total_s": time.perf_counter() - start, "paths": len(result.paths), "stages_s": result.timings_s,
        })
    return {"points": len(scan.points_m), "runs": runs}


def run_child(command: list[str]) -> tuple[str, float, float]:
    """Run `command`; return its stdout, wall time (s) and its own peak resident memory (MB).
    Exits with the child's message on stderr when it fails."""
    start = time.perf_counter()
    with subprocess.Popen(command, stdout=subprocess.PIPE, text=True) as child:
        output = child.stdout.read()
        _, status, usage = os.wait4(child.pid, 0)  # wait4: this child's rusage alone
        seconds = time.perf_counter() - start
        child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode:
        sys.exit(f"speed.py: {' '.join(command)} failed (exit {child.returncode})")
    return output, seconds, usage.ru_maxrss / 1024


def benchmark(names: list[str], repeat: int) -> dict:
    """Render, time and measure every scan; the results as plain data."""
    scans = []
    with tempfile.TemporaryDirectory() as folder:
        output, _, _ = run_child([sys.executable, SCRIPT, "--scans", ",".join(names), "--render-into", folder])
        origins = json.loads(output)
        for name in names:
            npy_path = os.path.join(folder, f"{name}.npy")
            # "=" form: an origin may start with "-", which parsers would take for an option.
            origin = "--camera-origin=" + ",".join(repr(v) for v in origins[name])
            print(f"timing {name} ...", file=sys.stderr)
            output, _, peak_mb = run_child(
                [sys.executable, SCRIPT, "--time-file", npy_path, origin, "--repeat", str(repeat)]
            )
            timed = json.loads(output)
            _, cli_s, cli_peak_mb = run_child(
                [WELDSEAM, "plan", npy_path, origin, "-o", os.path.join(folder, "out.json"), "--quiet"]
            )
            totals = [run["total_s"] for run in timed["runs"]]
            median_s = statistics.median(totals)
            scans.append({
                "scan": name, "seed": SEED, "points": timed["points"], "paths": timed["runs"][0]["paths"],
                "pipeline_median_s": median_s, "pipeline_max_s": max(totals), "peak_mb": peak_mb,
                "cli_s": cli_s, "cli_peak_mb": cli_peak_mb,
                "meets_target": median_s <= TARGET_S and peak_mb <= TARGET_MB,
                "runs": timed["runs"],
            })
    stages = list(scans[0]["runs"][0]["stages_s"])
    stage_ms = {
        stage: {
            **{scan["scan"]: 1000 * statistics.median(run["stages_s"][stage] for run in scan["runs"]) for scan in scans},
            "median": 1000 * statistics.median(run["stages_s"][stage] for scan in scans for run in scan["runs"]),
        }
        for stage in stages
    }
    return {"repeat": repeat, "target": {"pipeline_s": TARGET_S, "peak_mb": TARGET_MB}, "stage_ms": stage_ms, "scans": scans}


def report(results: dict) -> str:
    """The results as two text tables and the target verdict."""
    scans = results["scans"]
    names = [scan["scan"] for scan in scans]
    stage_rows = [
        [stage, *(f"{times[name]:.1f}" for name in names), f"{times['median']:.1f}"]
        for stage, times in results["stage_ms"].items()
    ]
    scan_rows = [
        [
            scan["scan"], f"{scan['points']:,}", str(scan["paths"]), f"{scan['pipeline_median_s']:.2f}",
            f"{scan['pipeline_max_s']:.2f}", f"{scan['peak_mb']:.0f}", f"{scan['cli_s']:.2f}",
            f"{scan['cli_peak_mb']:.0f}", "yes" if scan["meets_target"] else "NO",
        ]
        for scan in scans
    ]
    met = sum(scan["meets_target"] for scan in scans)
    return "\n".join([
        f"weldseam speed: {len(scans)} D415 640x480 scans (seed {SEED}), {results['repeat']} repeat(s) each",
        "",
        "per-stage time, ms (median over repeats; last column over repeats and scans)",
        format_table(["stage", *names, "median"], stage_rows),
        "",
        format_table(
            ["scan", "points", "paths", "median s", "max s", "peak MB", "cli s", "cli peak MB", "meets"], scan_rows
        ),
        "",
        f"target: <= {TARGET_S:.1f} s pipeline, <= {TARGET_MB / 1024:.0f} GB peak: {met} of {len(scans)} scans meet it",
    ])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scans", default=",".join(SCANS), help="Comma-separated scene families (default: %(default)s).")
    parser.add_argument("--repeat", type=int, default=3, help="Pipeline runs per scan (default: %(default)s).")
    parser.add_argument("--json", action="store_true", help="Print the results as JSON instead of tables.")
    # Hidden: the child processes this script starts.
    parser.add_argument("--render-into", help=argparse.SUPPRESS)
    parser.add_argument("--time-file", help=argparse.SUPPRESS)
    parser.add_argument("--camera-origin", help=argparse.SUPPRESS)
    args = parser.parse_args()
    names = args.scans.split(",")
    if args.render_into:
        print(json.dumps(render(names, args.render_into)))
    elif args.time_file:
        print(json.dumps(time_plan(args.time_file, args.camera_origin, args.repeat)))
    else:
        if args.repeat < 1:
            parser.error("--repeat must be at least 1")
        results = benchmark(names, args.repeat)
        print(json.dumps(results, indent=2) if args.json else report(results))


if __name__ == "__main__":
    main()
