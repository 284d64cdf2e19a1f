"""Score the planned paths against ground truth on every synthetic workpiece family.

Seed s of family f is rendered by weldseam.synthetic.catalog.draw_case(f, s): by default
exactly as
    rng = np.random.default_rng(s); scene = FAMILIES[f](rng); scan = make_scan(scene, rng)
(today's narrow distribution); with --broad from the broad one (clamps and loose bars, a
camera anywhere in the 45-degree cone that sees the seam, ripple, stereo shadow, a ragged
incidence limit); with --sensor hires through the 1944x1200 sensor. Then it is planned with
the default PlanConfig and scored with weldseam.synthetic.metrics.evaluate. Seeds 0 .. N-1
of every family run in a pool of worker processes (--first-seed F: seeds F .. F+N-1, e.g. 10-19,
which the planner was never developed on); the report does not depend on the number of workers
or on which finishes first.

--families takes family names and the groups classic (the ten families the planner was
developed in, the default), joints (one per further joint, and the curved valley) and all.

Examples:
    .venv/bin/python benchmarks/accuracy.py --families v_butt,fillet_t --seeds 3
    .venv/bin/python benchmarks/accuracy.py --broad --seeds 5
    .venv/bin/python benchmarks/accuracy.py --families joints --broad --seeds 5
    .venv/bin/python benchmarks/accuracy.py --broad --first-seed 10 --seeds 10
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import statistics
import sys
import time
import traceback


from weldseam.config import PlanConfig
from weldseam.pipeline.run import plan_paths
from weldseam.synthetic.catalog import ALL_FAMILIES, GROUPS, SENSORS, draw_case
from weldseam.synthetic.metrics import evaluate
from weldseam.types import Scan

from common import format_table, selected_families

MAX_ERROR_MM = 0.5
MIN_COVERAGE = 0.95
MAX_AXIS_ERROR_DEG = 3.0


def score(job: tuple[str, int, bool, str]) -> dict:
    """Render, plan and evaluate one (family, seed, broad, sensor). A crash is returned as its
    traceback, so one failing seed does not hide the others."""
    family, seed, broad, sensor = job
    try:
        scene, scan = draw_case(family, seed, broad=broad, sensor=sensor)
        start = time.perf_counter()
        result = plan_paths(
            Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source=f"{family} seed {seed}"),
            PlanConfig(), allow_empty=True,
        )
        seconds = time.perf_counter() - start
        metrics = evaluate(result.paths, scan, scene)
        metrics = {key: float(value) if isinstance(value, float) else value for key, value in metrics.items()}
        return {"family": family, "seed": seed, **metrics, "pipeline_s": seconds}
    except Exception:
        return {"family": family, "seed": seed, "error": traceback.format_exc()}


def _finite(values) -> list[float]:
    return [v for v in values if not math.isnan(v)]


def _mean(values) -> float:
    finite = _finite(values)
    return statistics.fmean(finite) if finite else math.nan


def summarise(family: str, runs: list[dict]) -> dict:
    """One family's figures over its seeds. Undefined values (NaN: no path, or no visible
    truth, e.g. a plain plate) are left out of means, minima and maxima."""
    scored = [run for run in runs if "error" not in run]
    errors_mm = _finite(run["mean_position_error_m"] * 1000 for run in scored)
    coverage = _finite(run["coverage"] for run in scored)
    return {
        "family": family,
        "seeds": len(runs),
        "crashed": len(runs) - len(scored),
        "count_correct": sum(run["seams_found"] == run["seams_expected"] for run in scored),
        "mean_error_mm": _mean(errors_mm),
        "worst_error_mm": max(errors_mm, default=math.nan),
        "coverage_mean": _mean(coverage),
        "coverage_min": min(coverage, default=math.nan),
        "axis_error_deg": _mean(run["mean_axis_error_deg"] for run in scored),
        "median_pipeline_s": statistics.median(run["pipeline_s"] for run in scored) if scored else math.nan,
    }


def _verdict(value: float, passes: bool) -> str:
    return "n/a" if math.isnan(value) else "PASS" if passes else "FAIL"


def acceptance(summary: dict) -> dict[str, str]:
    """PASS, FAIL or n/a (the figure is undefined) per criterion."""
    verdicts = {
        "count": "PASS" if summary["count_correct"] == summary["seeds"] else "FAIL",
        "error": _verdict(summary["mean_error_mm"], summary["mean_error_mm"] <= MAX_ERROR_MM),
        "coverage": _verdict(summary["coverage_mean"], summary["coverage_mean"] >= MIN_COVERAGE),
        "axis": _verdict(summary["axis_error_deg"], summary["axis_error_deg"] <= MAX_AXIS_ERROR_DEG),
    }
    verdicts["overall"] = "FAIL" if "FAIL" in verdicts.values() else "PASS"
    return verdicts


def _number(value: float, digits: int) -> str:
    return "-" if math.isnan(value) else f"{value:.{digits}f}"


def report(summaries: list[dict], seeds: range, workers: int, distribution: str) -> str:
    """The summaries as a figures table and an acceptance table."""
    figures = [
        [
            s["family"], str(s["seeds"]), f"{s['count_correct']}/{s['seeds']}", _number(s["mean_error_mm"], 3),
            _number(s["worst_error_mm"], 3), _number(s["coverage_mean"], 3), _number(s["coverage_min"], 3),
            _number(s["axis_error_deg"], 2), _number(s["median_pipeline_s"], 2), str(s["crashed"]),
        ]
        for s in summaries
    ]
    verdicts = [[s["family"], *s["acceptance"].values()] for s in summaries]
    passed = sum(s["acceptance"]["overall"] == "PASS" for s in summaries)
    return "\n".join([
        f"weldseam accuracy: {len(summaries)} families x {len(seeds)} seeds (seeds {seeds[0]}-{seeds[-1]}), "
        f"{distribution}, {workers} workers",
        "",
        format_table(
            ["family", "seeds", "count ok", "error mm", "worst mm", "cov mean", "cov min", "axis deg", "time s", "crashed"],
            figures,
        ),
        "",
        f"acceptance: seam count right in every seed, mean error <= {MAX_ERROR_MM} mm, "
        f"mean coverage >= {MIN_COVERAGE}, axis error <= {MAX_AXIS_ERROR_DEG:g} deg",
        format_table(["family", "count", "error", "coverage", "axis", "overall"], verdicts),
        "",
        f"{passed} of {len(summaries)} families pass",
    ])


def _json_ready(record: dict) -> dict:
    """NaN as null, so that strict JSON readers accept the output."""
    return {key: None if isinstance(value, float) and math.isnan(value) else value for key, value in record.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--families", default="classic",
                        help="Comma-separated families or groups: classic (default), joints, all.")
    parser.add_argument("--broad", action="store_true",
                        help="Draw from the broad distribution (clutter, camera cone, sensor realism).")
    parser.add_argument("--sensor", choices=SENSORS, default="d415", help="Sensor model (default: %(default)s).")
    parser.add_argument("--seeds", type=int, default=5, help="Seeds per family (default: %(default)s).")
    parser.add_argument("--first-seed", type=int, default=0, help="The first seed (default: %(default)s).")
    parser.add_argument("--workers", type=int, default=2, help="Worker processes (default: %(default)s).")
    parser.add_argument("--json", action="store_true", help="Print the results as JSON instead of tables.")
    args = parser.parse_args()
    families = selected_families(parser, args.families, ALL_FAMILIES, GROUPS)
    if args.seeds < 1 or args.workers < 1:
        parser.error("--seeds and --workers must be at least 1")
    if args.first_seed < 0:
        parser.error("--first-seed must be 0 or more")
    seeds = range(args.first_seed, args.first_seed + args.seeds)

    jobs = [(family, seed, args.broad, args.sensor) for family in families for seed in seeds]
    distribution = f"{'broad' if args.broad else 'default'} distribution, {args.sensor}"
    runs = []
    # spawn, not fork: the pipeline's KD-tree queries use threads, which fork does not carry safely.
    with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
        for run in pool.imap(score, jobs):  # imap keeps the job order
            runs.append(run)
            status = "CRASHED" if "error" in run else f"{run['pipeline_s']:.2f} s"
            print(f"[{len(runs)}/{len(jobs)}] {run['family']} seed {run['seed']}: {status}", file=sys.stderr)

    summaries = []
    for family in families:
        summary = summarise(family, [run for run in runs if run["family"] == family])
        summaries.append({**summary, "acceptance": acceptance(summary)})
    for run in runs:
        if "error" in run:
            print(f"\n{run['family']} seed {run['seed']} crashed:\n{run['error']}", file=sys.stderr)
    if args.json:
        print(json.dumps({
            "seeds": list(seeds), "broad": args.broad, "sensor": args.sensor, "families": [_json_ready(s) for s in summaries], "runs": [_json_ready(r) for r in runs],
        }, indent=2))
    else:
        print(report(summaries, seeds, args.workers, distribution))
    sys.exit(1 if any("error" in run for run in runs) else 0)


if __name__ == "__main__":
    main()
