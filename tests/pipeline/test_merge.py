"""weldseam.pipeline.merge: ICP refinement, de-duplication and per-point camera origins,
on rendered frames of the box whose groove runs up, over and down (truth known)."""

from dataclasses import asdict

import numpy as np
import pytest
from scipy.spatial import cKDTree

from weldseam.config import MergeConfig
from weldseam.geometry import transform_points
from weldseam.pipeline.merge import merge_frames
from weldseam.synthetic.multiview import box_groove_views, pose_error, render_views
from weldseam.synthetic.sensor import scan_points

PARAMS = {key: value for key, value in asdict(MergeConfig()).items() if key != "refine"}


@pytest.fixture(scope="module")
def box():
    rng = np.random.default_rng(3)
    scene, cameras = box_groove_views(rng)
    scans = render_views(scene, cameras, rng)
    errors = [np.eye(4)] + [pose_error(rng) for _ in scans[1:]]  # 2 mm / 1 deg on all but the reference
    poses = [scan.T_base_camera @ error for scan, error in zip(scans, errors)]
    frames = [scan_points(scan.depth, scan.intrinsics, pose) for scan, pose in zip(scans, poses)]
    return scene, scans, poses, frames


def seam_error_mm(scene, scan, placement):
    """Mean distance (mm) of the seam points this frame saw, carried by `placement` (4, 4), to the truth."""
    seam = scene.seams[0].points_m
    return cKDTree(seam).query(transform_points(placement, seam[scan.visible[0]]))[0].mean() * 1000


def test_icp_recovers_an_injected_pose_error(box):
    scene, scans, poses, frames = box
    merged = merge_frames(frames, np.array([p[:3, 3] for p in poses]), **PARAMS)
    assert merged.refined[1:].all() and np.array_equal(merged.corrections[0], np.eye(4))
    for k in (1, 2):
        # A truth point seen by frame k lands, in the merged cloud, at correction @ placed-by-the-wrong-pose.
        wrong = poses[k] @ np.linalg.inv(scans[k].T_base_camera)
        before = seam_error_mm(scene, scans[k], wrong)
        after = seam_error_mm(scene, scans[k], merged.corrections[k] @ wrong)
        assert before > 2.0 and after < 0.5, (k, before, after)


def test_without_refinement_the_poses_are_kept(box):
    _, _, poses, frames = box
    merged = merge_frames(frames, np.array([p[:3, 3] for p in poses]), refine=False, **PARAMS)
    assert not merged.refined.any() and np.array_equal(merged.corrections, np.tile(np.eye(4), (3, 1, 1)))


def test_overlap_holds_one_layer_and_every_point_keeps_its_camera(box):
    scene, scans, _, _ = box
    frames = [scan.points_m for scan in scans]
    origins = np.array([scan.camera_origin_m for scan in scans])
    merged = merge_frames(frames, origins, refine=False, **PARAMS)
    np.testing.assert_array_equal(merged.camera_origins_m, origins[merged.frame])
    # The top face, seen by all three views: merged, it is about as dense as its densest view,
    # not the sum of the three.
    top = scene.seams[0].points_m[:, 2].max()

    def on_top(points):
        return int((np.abs(points[:, 2] - top) < 0.002).sum())

    seen = [on_top(frame) for frame in frames]
    assert sum(seen) > 2 * max(seen)
    assert max(seen) <= on_top(merged.points_m) < 1.2 * max(seen)
    # Every kept point is one of its frame's points, unmoved.
    for k, frame in enumerate(frames):
        kept = merged.points_m[merged.frame == k]
        assert cKDTree(frame).query(kept)[0].max() == 0.0


def test_same_input_same_output(box):
    _, _, poses, frames = box
    first = merge_frames(frames, np.array([p[:3, 3] for p in poses]), **PARAMS)
    second = merge_frames(frames, np.array([p[:3, 3] for p in poses]), **PARAMS)
    assert first.points_m.tobytes() == second.points_m.tobytes()
    assert first.corrections.tobytes() == second.corrections.tobytes()


def test_a_frame_that_overlaps_nothing_keeps_its_pose():
    rng = np.random.default_rng(0)
    plane = np.column_stack([rng.uniform(0, 0.1, (20000, 2)), rng.normal(0, 0.0002, 20000)])
    far = plane + [1.0, 0.0, 0.0]
    merged = merge_frames([plane, far], np.array([[0.05, 0.05, 0.4], [1.05, 0.05, 0.4]]), **PARAMS)
    assert not merged.refined[1] and merged.overlap[1] == 0.0
    assert len(merged.points_m) == 40000


def test_per_point_camera_origins_orient_each_side_of_a_plate_toward_its_own_camera():
    """A 4 mm plate seen from above by one camera and from below by another: with one origin
    per point, both faces' normals point out of the plate; with one camera, the far face's
    would point into it."""
    from weldseam.pipeline.neighbours import radius_graph
    from weldseam.pipeline.normals import estimate_normals
    from weldseam.pipeline.support import find_support_plane

    rng = np.random.default_rng(0)
    top = np.column_stack([rng.uniform(0, 0.05, (3000, 2)), np.full(3000, 0.004)])
    bottom = np.column_stack([rng.uniform(0, 0.05, (3000, 2)), np.zeros(3000)])
    points = np.vstack([top, bottom])
    origins = np.repeat([[0.025, 0.025, 0.4], [0.025, 0.025, -0.4]], 3000, axis=0)
    normals = estimate_normals(points, radius_graph(points, 0.003), camera_origin_m=origins)
    assert (normals[:3000, 2] > 0.99).all() and (normals[3000:, 2] < -0.99).all()
    single = estimate_normals(points, radius_graph(points, 0.003), camera_origin_m=origins[0])
    assert (single[:, 2] > 0.99).all()
    flat = np.ones(len(points), dtype=bool)
    centre, normal = find_support_plane(top, flat[:3000], origins[:3000], tolerance_m=0.001, below_fraction=0.05)
    assert normal[2] > 0.99 and abs(centre[2] - 0.004) < 1e-9
