"""outline.outline_edges: where a frame's faces end at a real edge, against the grooved box's
known geometry, seen from three sides (above each end face and above the top)."""

import numpy as np
import pytest

from weldseam.geometry import transform_points
from weldseam.pipeline.outline import outline_edges
from weldseam.pipeline.patches import frame_patches
from weldseam.synthetic.multiview import box_groove_views, render_views

VOXEL_M = 0.004


@pytest.fixture(scope="module")
def box_edges():
    """The box's local frame (x along the groove, z up), its parts' extent in that frame, its
    top's height, and each view's edge samples expressed in that frame."""
    rng = np.random.default_rng(1)
    scene, cameras = box_groove_views(rng, cone=False)
    scans = render_views(scene, cameras, rng)
    seam = scene.seams[0].points_m
    along = seam[-1, :2] - seam[0, :2]
    angle = np.arctan2(along[1], along[0])
    to_local = np.eye(4)
    to_local[:2, :2] = [[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]]
    to_local[:3, 3] = -to_local[:3, :3] @ np.r_[seam.mean(axis=0)[:2], 0.0]
    corners = transform_points(to_local, np.vstack([part.vertices for part in scene.parts]))
    top_m = transform_points(to_local, seam)[:, 2].max()
    views = []
    for scan in scans:
        patches = frame_patches(scan.points_m, scan.camera_origin_m, VOXEL_M, 80.0)
        edges = outline_edges(patches, scan.points_m, scan.camera_origin_m, VOXEL_M)
        views.append((transform_points(to_local, edges.point), edges.normal @ to_local[:3, :3].T))
    return corners, top_m, views


def test_every_view_places_both_ends_of_the_top(box_edges):
    """Views above an end face see that end as a crease (placed by the two faces' planes: within
    0.5 mm) and the far end as the near side of a depth jump (its last points: within 2 mm, a
    stereo sensor fattens a foreground edge); the view above the top sees both as jumps."""
    corners, top_m, views = box_edges
    on_top = np.abs(corners[:, 2] - top_m) < 1e-6
    ends = corners[on_top, 0].min(), corners[on_top, 0].max()
    creases = {(0, 0), (2, 1)}  # (view, end): the views above the -x and the +x face
    for view, (points, outward) in enumerate(views):
        near_top = np.abs(points[:, 2] - top_m) < 0.003
        for side, (end, sign) in enumerate(zip(ends, (-1.0, 1.0))):
            here = near_top & (outward[:, 0] * sign > 0.9)
            assert here.sum() >= 5
            tolerance_m = 0.0005 if (view, side) in creases else 0.002
            assert abs(np.median(points[here, 0]) - end) < tolerance_m, (view, side, np.median(points[here, 0]) - end)


def test_no_edge_where_a_shadow_cuts_the_table(box_edges):
    """The table's samples near the box lie at its foot (a crease): the border of the box's
    shadow, a line 60 mm or more long that moves with the camera, gives at most a stray sample."""
    corners, _, views = box_edges
    low, high = corners[:, :2].min(axis=0), corners[:, :2].max(axis=0)
    for points, _ in views:
        outside = np.linalg.norm(np.maximum(np.maximum(low - points[:, :2], points[:, :2] - high), 0.0), axis=1)
        near_box = (points[:, 2] < 0.003) & (outside < 0.1)
        assert near_box.sum() >= 20 and (outside[near_box] > 0.004).sum() <= 1
