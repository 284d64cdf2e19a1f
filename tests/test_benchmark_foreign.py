"""benchmarks/foreign.py reports each failing case with the error and coverage the scorer measured:
a case that fails before and after a change may still lose ground. Where the independent scans are
(../shared/foreign, read in place, never copied), every further joint of theirs passes."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# A stand-in for the folder's tools/run.py: it writes the results JSON the real one writes.
FAKE_RUN = """
import json, sys
out = sys.argv[sys.argv.index("--out") + 1]
case = {"case": "m_square_butt_00", "family": "m_square_butt", "passed": False, "reasons": ["cov<0.95"],
        "err_mean_mm": 0.7465, "coverage_min": 0.616}
json.dump({"totals": {"n": 1, "passed": 0, "by_family": {"m_square_butt": {"n": 1, "passed": 0}},
                      "mean_wall_s": 1.0},
           "cases": [case]}, open(out, "w"))
"""


def run_foreign(tmp_path, *options):
    (tmp_path / "tools").mkdir()
    (tmp_path / "tools" / "run.py").write_text(FAKE_RUN)
    result = subprocess.run(
        [sys.executable, "benchmarks/foreign.py", "--foreign", str(tmp_path), "--sets", "joints", *options],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_a_failing_case_shows_its_error_and_coverage(tmp_path):
    out = run_foreign(tmp_path)
    assert "joints: 0/1 pass" in out
    assert "  m_square_butt_00: cov<0.95 (error 0.75 mm, coverage 0.616)" in out


def test_the_json_report_keeps_each_cases_coverage(tmp_path):
    case = json.loads(run_foreign(tmp_path, "--json"))["joints"]["cases"][0]
    assert case["coverage_min"] == 0.616 and case["err_mean_mm"] == 0.7465


FOREIGN = ROOT.parent / "shared" / "foreign"


@pytest.mark.skipif(not (FOREIGN / "joints").is_dir(), reason="the independent scans (../shared/foreign) are not here")
def test_every_further_joint_of_the_independent_generator_passes_its_scorer():
    """The independent generator's further joints (lap, pipe on a plate, saddle, bevel, square butt,
    tacks with clutter, outside corner), read in place and scored by that folder's own scorer:
    right count, <= 1.0 mm, >= 95 % within 2 mm, <= 5 degrees."""
    result = subprocess.run(
        [sys.executable, "benchmarks/foreign.py", "--foreign", str(FOREIGN), "--sets", "joints", "--json"],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    cases = json.loads(result.stdout)["joints"]["cases"]
    failed = {case["case"]: case["reasons"] for case in cases if not case["passed"]}
    assert len(cases) == 7 and not failed, failed
