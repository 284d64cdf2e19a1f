"""benchmarks/accuracy.py draws the seeds it is asked for: --first-seed F --seeds N is F .. F+N-1."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_seed_range_starts_at_first_seed():
    result = subprocess.run(
        [sys.executable, "benchmarks/accuracy.py", "--families", "plain_plate", "--first-seed", "12", "--seeds", "2",
         "--workers", "1", "--json"],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["seeds"] == [12, 13]
    assert [run["seed"] for run in report["runs"]] == [12, 13]
    assert all(run["seams_found"] == 0 for run in report["runs"])  # a plain plate has no seam


def test_a_negative_first_seed_is_refused():
    result = subprocess.run([sys.executable, "benchmarks/accuracy.py", "--first-seed", "-1"], cwd=ROOT,
                            capture_output=True, text=True, timeout=60)  # fmt: skip
    assert result.returncode == 2 and "--first-seed must be 0 or more" in result.stderr
