"""evaluate(): a path made from the truth scores perfectly; known offsets score as offset."""

from dataclasses import replace

import numpy as np
import pytest

from weldseam.geometry import frames_from_axes
from weldseam.synthetic.metrics import evaluate
from weldseam.synthetic.scenes import make_scan, plain_plate, ring_groove, v_butt, y_groove
from weldseam.types import WeldPath


def _truth_paths(scene, scan, step=1, offset_m=0.0, tilt_deg=0.0, joints=None):
    """One WeldPath per seam through its visible truth points (every `step`-th and the last), moved
    `offset_m` along the tool x axis and tilted `tilt_deg` about the travel axis, each naming
    its seam's joint kind (or `joints[k]`)."""
    paths = []
    for k, (seam, visible) in enumerate(zip(scene.seams, scan.visible)):
        keep = np.unique(np.r_[0 : visible.sum() : step, visible.sum() - 1])
        points, axes = seam.points_m[visible][keep], seam.torch_axes[visible][keep]
        frames = frames_from_axes(axes, np.gradient(points, axis=0))
        angle = np.radians(tilt_deg)
        turn = np.array([[np.cos(angle), 0, np.sin(angle)], [0, 1, 0],
                         [-np.sin(angle), 0, np.cos(angle)]])
        paths.append(WeldPath(k, points + offset_m * frames[:, :, 0], frames @ turn,
                              closed=seam.closed and visible.all(),
                              joint=seam.joint if joints is None else joints[k]))
    return paths


@pytest.fixture(scope="module")
def butt():
    rng = np.random.default_rng(20)
    scene = v_butt(rng)
    return scene, make_scan(scene, rng)


def test_truth_path_scores_perfectly(butt):
    scene, scan = butt
    result = evaluate(_truth_paths(scene, scan), scan, scene)
    assert result["seams_found"] == result["seams_expected"] == result["seams_matched"] == 1
    assert result["mean_position_error_m"] < 1e-9
    assert result["max_position_error_m"] < 1e-9
    assert result["coverage"] == pytest.approx(1.0)
    assert result["mean_axis_error_deg"] < 1e-6


def test_one_millimetre_offset_scores_one_millimetre_and_still_covers(butt):
    scene, scan = butt
    result = evaluate(_truth_paths(scene, scan, offset_m=0.001), scan, scene)
    assert result["mean_position_error_m"] == pytest.approx(0.001, abs=2e-5)
    assert result["coverage"] == pytest.approx(1.0)
    far = evaluate(_truth_paths(scene, scan, offset_m=0.003), scan, scene)
    assert far["coverage"] == 0.0 and far["seams_matched"] == 0


def test_sparse_poses_are_scored_between_them_and_tilt_shows_as_axis_error(butt):
    scene, scan = butt
    result = evaluate(_truth_paths(scene, scan, step=20, tilt_deg=10.0), scan, scene)
    assert result["coverage"] > 0.99
    assert result["mean_position_error_m"] < 1e-9
    assert result["mean_axis_error_deg"] == pytest.approx(10.0, abs=1e-6)


def test_half_a_seam_covers_half():
    rng = np.random.default_rng(21)
    scene = v_butt(rng)
    scan = make_scan(scene, rng)
    path = _truth_paths(scene, scan)[0]
    half = len(path.positions_m) // 2
    result = evaluate([WeldPath(0, path.positions_m[:half], path.rotations[:half])], scan, scene)
    assert result["coverage"] == pytest.approx(0.5, abs=0.01)


def test_closed_ring_and_branches():
    rng = np.random.default_rng(22)
    for scene in (ring_groove(rng), y_groove(rng)):
        scan = make_scan(scene, rng)
        result = evaluate(_truth_paths(scene, scan, step=10), scan, scene)
        assert result["seams_expected"] == result["seams_matched"] == len(scene.seams)
        assert result["coverage"] > 0.99
    missing_branch = evaluate(_truth_paths(scene, scan)[:2], scan, scene)
    assert missing_branch["seams_matched"] == 2 and missing_branch["coverage"] < 0.9


def test_nothing_to_find_and_nothing_found():
    rng = np.random.default_rng(23)
    scene = plain_plate(rng)
    scan = make_scan(scene, rng)
    result = evaluate([], scan, scene)
    assert result["seams_found"] == result["seams_expected"] == 0
    assert np.isnan(result["coverage"]) and np.isnan(result["mean_position_error_m"])
    scene = v_butt(rng)
    result = evaluate([], make_scan(scene, rng), scene)
    assert result["seams_expected"] == 1 and result["coverage"] == 0.0


def test_each_seam_counts_as_kind_matched_only_when_its_path_names_its_kind():
    from weldseam.synthetic.joints import lap_and_fillet

    rng = np.random.default_rng(24)
    scene = lap_and_fillet(rng, mount="table")
    scan = make_scan(scene, rng)
    assert [seam.joint for seam in scene.seams] == ["lap", "fillet"]
    assert evaluate(_truth_paths(scene, scan), scan, scene)["kinds_matched"] == 2
    assert evaluate(_truth_paths(scene, scan, joints=["fillet", "fillet"]), scan, scene)["kinds_matched"] == 1
    assert evaluate(_truth_paths(scene, scan, joints=["fillet", "lap"]), scan, scene)["kinds_matched"] == 0
    assert evaluate(_truth_paths(scene, scan, offset_m=0.003), scan, scene)["kinds_matched"] == 0, "paths elsewhere"


def test_poses_on_a_stretch_the_mask_calls_unseen_are_on_the_seam_but_do_not_cover_it(butt):
    """The visible mask is a conservative view cone: a planner that measures a stretch beyond it
    is on the seam there (no position or axis error); coverage still counts only what the mask
    marks as seen, and poses off the seam there are errors."""
    scene, scan = butt
    seam = scene.seams[0]
    half = len(seam.points_m) // 2
    unseen_half = replace(scan, visible=(np.arange(len(seam.points_m)) < half,))
    frames = frames_from_axes(seam.torch_axes, np.gradient(seam.points_m, axis=0))
    whole = WeldPath(0, seam.points_m, frames, joint=seam.joint)
    result = evaluate([whole], unseen_half, scene)
    assert result["mean_position_error_m"] < 1e-9 and result["mean_axis_error_deg"] < 1e-6
    assert result["coverage"] == pytest.approx(1.0)
    beyond = WeldPath(0, seam.points_m[half:], frames[half:], joint=seam.joint)
    assert evaluate([beyond], unseen_half, scene)["coverage"] < 0.02
    off = WeldPath(0, seam.points_m + 0.002 * frames[:, :, 0], frames, joint=seam.joint)
    assert evaluate([off], unseen_half, scene)["mean_position_error_m"] == pytest.approx(0.002, abs=5e-5)
