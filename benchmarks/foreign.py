"""How weldseam does on scans it did not make: the independent scans in ../shared/foreign, run
through the real CLI and scored by that folder's own scorer (tools/run.py, tools/check_real.py).

    .venv/bin/python benchmarks/foreign.py                  # every set, ~5 minutes on 2 cores
    .venv/bin/python benchmarks/foreign.py --sets single,joints --json

Sets: single (each case's cloud.ply with its camera origin), depth (the same cases as depth.png,
intrinsics and camera pose), joints (further joints, cloud), hires (1944x1200 depth), multiview
(several depth frames through --frames) and real (real scans against their loose expected lines).
Pass (the scorer's): seam count right, mean position error <= 1.0 mm, >= 95 % of the seam within
2 mm of a pose, mean torch-axis error <= 5 deg; negative cases pass with no seam. Each set also
shows its pooled mean position error: the mean of the per-case mean errors over every case that
gave a path (passed or not). Without the folder it says so and exits 0: nothing here is ours to ship.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WELDSEAM = ROOT / ".venv" / "bin" / "weldseam"
PLAN_CLOUD = f"{WELDSEAM} plan {{cloud}} --camera-origin \"$(cat {{camera_origin}})\" -o {{out}}"
PLAN_DEPTH = f"{WELDSEAM} plan {{depth}} --intrinsics {{intrinsics}} --camera-pose {{camera_pose}} -o {{out}}"
# (cases folder, --input, command template, timeout s) per set, as the folder's README runs them.
SETS = {
    "single": ("single", "cloud", PLAN_CLOUD, 120),
    "depth": ("single", "depth", PLAN_DEPTH, 120),
    "joints": ("joints", "cloud", PLAN_CLOUD, 120),
    "hires": ("hires", "depth", PLAN_DEPTH, 300),
    "multiview": ("multiview", "manifest", "PYTHON TOOLS/to_frames.py {manifest} {out}.frames.json && "
                  f"{WELDSEAM} plan --frames {{out}}.frames.json -o {{out}}", 300),
}


# What the JSON report keeps of each case (the scorer's coverage_min: the least covered seam's share).
CASE_KEYS = ("case", "family", "passed", "reasons", "err_mean_mm", "coverage_min")


def run_set(name: str, foreign: Path, work: Path) -> dict:
    """The scorer's totals and cases for one set (tools/run.py's results JSON)."""
    folder, kind, template, timeout = SETS[name]
    command = template.replace("PYTHON", sys.executable).replace("TOOLS", str(foreign / "tools"))
    results = work / f"{name}.json"
    subprocess.run(
        [sys.executable, str(foreign / "tools" / "run.py"), "--cases", str(foreign / folder), "--input", kind,
         "--out", str(results), "--timeout", str(timeout), "--cmd", command],
        check=True, stdout=subprocess.DEVNULL, cwd=ROOT,
    )
    return json.loads(results.read_text())


def pooled_error_mm(cases: list[dict]) -> float | None:
    """Mean position error (mm) pooled over the cases that gave a path: the mean of their means."""
    errors = [case["err_mean_mm"] for case in cases if case.get("err_mean_mm") is not None]
    return sum(errors) / len(errors) if errors else None


def run_real(foreign: Path) -> dict:
    """check_real.py's verdict per real scan: {scan: verdict line}."""
    done = subprocess.run(
        [sys.executable, str(foreign / "tools" / "check_real.py"), "--cmd",
         f"{WELDSEAM} plan {{cloud}} --camera-origin {{camera_origin}} -o {{out}}"],
        capture_output=True, text=True, cwd=ROOT,
    )
    return {"exit": done.returncode, "lines": [line for line in done.stdout.splitlines() if line.strip()]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--foreign", type=Path, default=ROOT.parent / "shared" / "foreign")
    parser.add_argument("--sets", default=",".join([*SETS, "real"]), help="comma list of " + ", ".join([*SETS, "real"]))
    parser.add_argument("--json", action="store_true", help="print the results as JSON instead of tables")
    args = parser.parse_args()
    if not (args.foreign / "tools" / "run.py").is_file():
        print(f"{args.foreign}: no independent scans here; nothing to measure", file=sys.stderr)
        return 0
    names = [name for name in args.sets.split(",") if name]
    unknown = [name for name in names if name not in SETS and name != "real"]
    if unknown:
        parser.error(f"unknown set(s) {', '.join(unknown)}; choose from {', '.join([*SETS, 'real'])}")
    report = {}
    with tempfile.TemporaryDirectory() as work:
        for name in names:
            print(f"{name} ...", file=sys.stderr, flush=True)
            report[name] = run_real(args.foreign) if name == "real" else run_set(name, args.foreign, Path(work))
    if args.json:
        print(json.dumps({name: value if name == "real" else value["totals"] | {
            "pooled_error_mm": pooled_error_mm(value["cases"]), "cases": [
            {key: case.get(key) for key in CASE_KEYS} for case in value["cases"]]}
            for name, value in report.items()}, indent=1))
        return 0
    for name, value in report.items():
        if name == "real":
            print(f"\nreal (check_real.py, exit {value['exit']}):")
            print("\n".join(f"  {line}" for line in value["lines"]))
            continue
        totals = value["totals"]
        families = ", ".join(f"{family} {d['passed']}/{d['n']}" for family, d in sorted(totals["by_family"].items()))
        error_mm = pooled_error_mm(value["cases"])
        error = "no path" if error_mm is None else f"mean error {error_mm:.2f} mm"
        print(f"{name}: {totals['passed']}/{totals['n']} pass ({families}); {error}; "
              f"mean {totals['mean_wall_s']:.1f} s a case")
        for case in value["cases"]:
            if not case["passed"]:
                print(failing_line(case))
    return 0


def failing_line(case: dict) -> str:
    """A failing case's line: why it fails, and the error and coverage the scorer measured (a case
    that fails before and after a change may still lose ground: a square butt covered 84 -> 62 %)."""
    def measured(key: str, form: str) -> str:
        return "-" if case.get(key) is None else format(case[key], form)
    return (f"  {case['case']}: {'; '.join(case['reasons'])} (error {measured('err_mean_mm', '.2f')} mm, "
            f"coverage {measured('coverage_min', '.3f')})")


if __name__ == "__main__":
    sys.exit(main())
