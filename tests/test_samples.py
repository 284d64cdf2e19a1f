"""The bundled samples: their paths lie on their ground truth and match the golden files."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from weldseam.io.paths import read_paths

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "samples"
COMMANDS = {
    "v_butt": ["v_butt.ply", "--camera-pose", "v_butt.pose.json"],
    "fillet_t": ["fillet_t.png", "--intrinsics", "d415.intrinsics.json", "--camera-pose", "fillet_t.pose.json"],
}


@pytest.fixture(scope="module", params=sorted(COMMANDS))
def planned(request, tmp_path_factory):
    name = request.param
    out = tmp_path_factory.mktemp(name) / f"{name}.json"
    result = subprocess.run(
        [sys.executable, "-m", "weldseam.cli", "plan", *COMMANDS[name], "-o", str(out), "-q"],
        cwd=SAMPLES, capture_output=True, timeout=120,
    )
    assert result.returncode == 0, result.stderr.decode()
    return name, out


def test_sample_path_lies_on_the_seam_the_camera_saw(planned):
    name, out = planned
    truth = json.loads((SAMPLES / f"{name}.truth.json").read_text())["seams"]
    points = np.vstack([seam["points_m"] for seam in truth])
    axes = np.vstack([seam["torch_axes"] for seam in truth])
    paths = read_paths(out)
    assert len(paths) == len(truth)
    poses = np.vstack([p.positions_m for p in paths])
    distance, nearest = cKDTree(points).query(poses)
    assert distance.mean() < 0.0005 and distance.max() < 0.002
    torch = np.vstack([p.rotations[:, :, 2] for p in paths])
    angle = np.degrees(np.arccos(np.clip(np.sum(torch * axes[nearest], axis=1), -1, 1)))
    assert angle.mean() < 3.0
    covered = cKDTree(poses).query(points)[0] <= 0.002 + 0.001  # poses every 2 mm
    assert covered.mean() > 0.9


def test_sample_path_matches_its_golden_file(planned):
    name, out = planned
    golden = read_paths(SAMPLES / "golden" / f"{name}.json")
    ours = read_paths(out)
    assert [len(p.positions_m) for p in ours] == [len(p.positions_m) for p in golden]
    for a, b in zip(ours, golden):
        assert np.allclose(a.positions_m, b.positions_m, atol=1e-6)
        assert np.allclose(a.rotations, b.rotations, atol=1e-6)
