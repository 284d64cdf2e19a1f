"""`weldseam plan` over several frames of one workpiece, through the real CLI, scored against
the synthetic truth: one continuous seam over a box's three faces, one closed pipe ring,
with and without a 2 mm / 1 deg pose error on every frame but the first (the reference:
ICP aligns the others to it, so its own pose error would pass to the path unchanged).
Accuracy as in test_acceptance.py, over the truth any frame saw."""

import json

import numpy as np
import pytest
from PIL import Image

from tests.test_cli import weldseam
from weldseam.io.depth import write_intrinsics
from weldseam.io.paths import read_paths
from weldseam.synthetic.metrics import evaluate
from weldseam.synthetic.multiview import (
    box_groove_views,
    pipe_ring_views,
    pose_error,
    render_views,
    seen_by_any,
    write_frame_set,
)

VIEWS = {"box": box_groove_views, "pipe": pipe_ring_views}
# Seeds 0 and 1 of each scene (box: 3 views, pipe: 4 views), not chosen for passing.
CASES = [("box", 0, True), ("box", 1, False), ("box", 1, True), ("pipe", 0, True), ("pipe", 1, False),
         ("pipe", 1, True)]
# Known gaps, strict xfails (a fix makes them fail until removed); they lie in seam tracing and
# assembly on merged clouds, not in the merge (ICP leaves each frame within ~0.3 mm, see
# tests/pipeline/test_merge.py), and come and go with the noise: with exact poses and ICP off,
# seeds 0-4 pass every criterion for 1 box and 1 pipe (with ICP on: 0 and 2).
KNOWN_GAPS: dict[tuple, set[str]] = {}


def known_gap(request, planned, criterion):
    if criterion in KNOWN_GAPS.get(planned[4], ()):
        request.applymarker(pytest.mark.xfail(strict=True, reason="known gap"))


def manifest_frames(folder, scans, poses):
    """Depth PNGs, intrinsics and a manifest with each frame's camera pose: `plan --frames`."""
    frames = []
    for index, (scan, pose) in enumerate(zip(scans, poses)):
        Image.fromarray(scan.depth).save(folder / f"f{index}.png")
        frames.append({"scan": f"f{index}.png", "intrinsics": "d415.json", "T_base_camera": pose.tolist()})
    write_intrinsics(folder / "d415.json", scans[0].intrinsics)
    (folder / "frames.json").write_text(json.dumps({"frames": frames}))
    return ["--frames", folder / "frames.json"]


def sidecar_frames(folder, scans, poses):
    """Depth PNGs each with NAME.pose.json holding the flange pose of an eye-in-hand camera,
    intrinsics.json and the hand-eye file: `plan F0 F1 ... --hand-eye`."""
    return [*write_frame_set(folder, scans, poses), "--hand-eye", folder / "H.json"]


@pytest.fixture(scope="module", params=CASES, ids=lambda p: f"{p[0]}-{p[1]}-{'pose-error' if p[2] else 'exact'}")
def planned(request, tmp_path_factory):
    name, seed, with_error = request.param
    rng = np.random.default_rng(seed)
    scene, cameras = VIEWS[name](rng)
    scans = render_views(scene, cameras, rng)
    poses = [s.T_base_camera @ (pose_error(rng) if with_error and k else np.eye(4)) for k, s in enumerate(scans)]
    folder = tmp_path_factory.mktemp(name)
    # The box with pose error goes through sidecar flange poses and a hand-eye file, the rest
    # through a manifest of camera poses.
    inputs = (sidecar_frames if (name, with_error) == ("box", True) else manifest_frames)(folder, scans, poses)
    result = weldseam("plan", *inputs, "-o", folder / "path.json")
    assert result.returncode == 0, result.stderr.decode()
    paths = read_paths(folder / "path.json")
    record = json.loads((folder / "path.json").read_text())
    return name, paths, evaluate(paths, seen_by_any(scans), scene), record, request.param


def test_one_seam_continuous_over_the_overlap(request, planned):
    known_gap(request, planned, "continuous")
    name, paths, metrics, _, _ = planned
    assert len(paths) == 1, metrics
    steps = np.linalg.norm(np.diff(paths[0].positions_m, axis=0), axis=1)
    assert steps.max() < 0.004  # no jump: one continuous path, poses every 2 mm
    assert paths[0].closed == (name == "pipe")


def test_accuracy_as_for_a_single_scan(request, planned):
    known_gap(request, planned, "accuracy")
    _, _, metrics, _, _ = planned
    assert metrics["mean_position_error_m"] <= 0.0005, metrics
    assert metrics["coverage"] >= 0.95, metrics
    assert metrics["mean_axis_error_deg"] <= 3.0, metrics


def test_record_lists_the_frames_and_their_icp_corrections(planned):
    _, _, _, record, _ = planned
    frames = record["input"]["frames"]
    assert len(frames) >= 3 and frames[0]["icp_shift_mm"] == 0.0
    assert all(0 < f["kept_points"] <= f["points"] for f in frames)
