"""`plan -v` tells what became of every seam candidate, and a scan without a seam says why."""

import json

import numpy as np
import pytest

from tests.test_cli import weldseam
from weldseam.synthetic.scenes import FAMILIES, make_scan


@pytest.fixture(scope="module")
def plate_on_table(tmp_path_factory):
    """A plain plate lying on the table: its edges are creases, none of them a joint."""
    rng = np.random.default_rng(0)
    scene = FAMILIES["plain_plate"](rng)
    scan = make_scan(scene, rng)
    path = tmp_path_factory.mktemp("plate") / "plate.npy"
    np.save(path, scan.points_m)
    return path, ",".join(f"{v:.6f}" for v in scan.camera_origin_m)


def test_verbose_lists_each_rejected_candidate_with_where_it_lies_and_why(plate_on_table, tmp_path):
    path, origin = plate_on_table
    result = weldseam("plan", path, "--camera-origin", origin, "-o", tmp_path / "p.json", "-v")
    assert result.returncode == 3
    lines = result.stderr.decode().splitlines()
    candidates = [line for line in lines if line.lstrip().startswith("candidate ")]
    assert len(candidates) >= 4  # the plate's edges at least
    assert all(" mm, " in line and "mm: " in line for line in candidates)
    assert any("no joint model fits its sections (v_groove: " in line for line in candidates)
    assert not any(": seam " in line for line in candidates)
    assert lines[-1].startswith(f"Error: {path}: no weld seam found (")
    assert "candidate(s) rejected: " in lines[-1] and "no joint model fits its sections" in lines[-1]
    assert not (tmp_path / "p.json").exists()


def test_without_verbose_the_error_is_one_line(plate_on_table, tmp_path):
    path, origin = plate_on_table
    result = weldseam("plan", path, "--camera-origin", origin, "-o", tmp_path / "p.json")
    assert result.returncode == 3
    assert len(result.stderr.decode().strip().splitlines()) == 1


def test_a_flat_plate_has_no_candidate_and_says_nothing_bends_enough(tmp_path):
    rng = np.random.default_rng(3)
    grid = np.stack(np.meshgrid(np.arange(0, 0.2, 0.0008), np.arange(0, 0.15, 0.0008)), -1).reshape(-1, 2)
    plate = tmp_path / "plate.npy"
    np.save(plate, np.column_stack([grid, rng.normal(0, 0.0003, len(grid))]))
    result = weldseam("plan", plate, "--camera-origin", "0.1,0.07,0.45", "-o", tmp_path / "p.json", "-v")
    assert result.returncode == 3
    error = result.stderr.decode().strip().splitlines()[-1]
    assert error == (f"Error: {plate}: no weld seam found (nothing in the scan bends like a crease of "
                     "segment.min_crease_deg (20 deg))")


def test_the_record_lists_every_candidate_and_the_seam_each_became(tmp_path):
    out = tmp_path / "path.json"
    result = weldseam("plan", "samples/v_butt.ply", "--camera-pose", "samples/v_butt.pose.json", "-o", out, "-q")
    assert result.returncode == 0
    record = json.loads(out.read_text())
    found = record["candidates"]
    assert any(c["seam"] == 0 and c["rejected"] is None for c in found)
    rejected = [c for c in found if c["rejected"] is not None]
    assert rejected and all(c["seam"] is None and c["reason"] for c in rejected)
    assert all(len(c["centre_m"]) == 3 and c["length_m"] > 0 for c in found)


def test_dump_stages_writes_every_candidates_points_however_many(plate_on_table, tmp_path):
    path, origin = plate_on_table
    # A crease rule of 8 degrees makes ~150 candidates of the plate's noise, each dumped at several steps.
    result = weldseam("plan", path, "--camera-origin", origin, "-o", tmp_path / "p.json", "--dump-stages",
                      tmp_path / "dump", "--set", "segment.min_crease_deg=8")
    assert result.returncode == 3 and "Traceback" not in result.stderr.decode()
    names = sorted(p.name for p in (tmp_path / "dump").iterdir())
    assert len(names) > 200
    assert names[0] == "000_condition.ply" and len(set(names)) == len(names)
    assert sum(name.endswith("_order.ply") for name in names) >= 100
