"""`weldseam compare`, run as CI would run it on golden files."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "samples" / "golden"


def weldseam(*args):
    return subprocess.run(
        [sys.executable, "-m", "weldseam.cli", *map(str, args)], capture_output=True, timeout=120, cwd=ROOT
    )


def shifted_copy(source: Path, target: Path, dy_m: float) -> Path:
    document = json.loads(source.read_text())
    for seam in document["seams"]:
        for pose in seam["poses"]:
            pose["y"] += dy_m
    target.write_text(json.dumps(document))
    return target


SAMPLE_PLANS = {
    "v_butt": ["samples/v_butt.ply", "--camera-pose", "samples/v_butt.pose.json"],
    "fillet_t": [
        "samples/fillet_t.png",
        "--intrinsics",
        "samples/d415.intrinsics.json",
        "--camera-pose",
        "samples/fillet_t.pose.json",
    ],
}


@pytest.mark.parametrize("name", sorted(SAMPLE_PLANS))
def test_the_plan_of_a_committed_sample_matches_its_golden_file(tmp_path, name):
    out = tmp_path / f"{name}.json"
    planned = weldseam("plan", *SAMPLE_PLANS[name], "-o", out, "-q")
    assert planned.returncode == 0, planned.stderr
    result = weldseam("compare", out, GOLDEN / f"{name}.json", "--tol-mm", "0.001", "--tol-deg", "0.001")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "within 0.001 mm" in result.stderr.decode()


def test_outside_tolerance_exits_1_with_the_deviation_in_json(tmp_path):
    shifted = shifted_copy(GOLDEN / "v_butt.json", tmp_path / "shifted.json", 0.0003)
    inside = weldseam("compare", shifted, GOLDEN / "v_butt.json", "--tol-mm", "0.5", "--json")
    outside = weldseam("compare", shifted, GOLDEN / "v_butt.json", "--tol-mm", "0.2", "--json")
    assert inside.returncode == 0 and outside.returncode == 1
    report = json.loads(outside.stdout)
    assert report["within_tolerance"] is False
    assert report["seams"][0]["max_deviation_mm"] == pytest.approx(0.3, abs=1e-6)


def test_a_csv_compares_with_a_json_of_the_same_path(tmp_path):
    csv = tmp_path / "v_butt.csv"
    planned = weldseam("plan", "samples/v_butt.ply", "--camera-pose", "samples/v_butt.pose.json", "-o", csv, "-q")
    assert planned.returncode == 0, planned.stderr
    assert weldseam("compare", csv, GOLDEN / "v_butt.json", "--tol-mm", "0.001", "--tol-deg", "0.001").returncode == 0


def test_different_parts_do_not_match():
    result = weldseam("compare", GOLDEN / "v_butt.json", GOLDEN / "fillet_t.json")
    assert result.returncode == 1
    assert "unmatched" in result.stdout.decode()


@pytest.mark.parametrize("content", [None, "not json", '{"format": "other"}'])
def test_an_unreadable_file_exits_2_with_one_line(tmp_path, content):
    bad = tmp_path / "bad.json"
    if content is not None:
        bad.write_text(content)
    result = weldseam("compare", bad, GOLDEN / "v_butt.json")
    assert result.returncode == 2 and result.stdout == b""
    lines = result.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {bad}")
