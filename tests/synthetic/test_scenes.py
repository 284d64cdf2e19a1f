"""Synthetic scenes: exact geometry, truth where the definition puts it, visible seams."""

import dataclasses

import numpy as np
import pytest

from weldseam.geometry import unit
from weldseam.synthetic.scenes import (
    FAMILIES, block_groove, curved_groove, default_camera, fillet_t, make_scan, pixel_of, returned_mask, visible_mask,
    v_butt,
)
from weldseam.synthetic.sensor import D415, SensorNoise, cast_rays, look_at

FINE = dataclasses.replace(D415, depth_scale=1e5)  # 10 um depth units for sub-mm checks


def _visible_length(seam, visible):
    both = visible[:-1] & visible[1:]
    return np.linalg.norm(np.diff(seam.points_m, axis=0), axis=1)[both].sum()


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_family_builds_renders_and_shows_its_seams(family):
    rng = np.random.default_rng(7)
    scene = FAMILIES[family](rng)
    assert all(part.is_volume for part in scene.mesh.split())  # watertight, outward, > 0
    scan = make_scan(scene, rng)
    assert len(scan.points_m) > 50_000
    assert np.all(np.abs(scan.camera_origin_m - scene.camera_target_m) < 0.7)
    for seam in scene.seams:
        assert seam.points_m.shape == seam.torch_axes.shape
        assert np.allclose(np.linalg.norm(seam.torch_axes, axis=1), 1.0)
        assert np.linalg.norm(np.diff(seam.points_m, axis=0), axis=1).max() <= 0.00051
    lengths = [_visible_length(s, v) for s, v in zip(scene.seams, scan.visible)]
    if family == "plain_plate":
        assert scene.seams == ()
    elif family in ("two_grooves", "y_groove"):
        assert min(lengths) >= 0.05
    else:
        assert max(lengths) >= 0.05


def test_clean_render_lies_on_the_mesh():
    import open3d as o3d

    rng = np.random.default_rng(8)
    scene = v_butt(rng)
    scan = make_scan(scene, rng, SensorNoise.clean(), intrinsics=FINE)
    raycaster = o3d.t.geometry.RaycastingScene()
    raycaster.add_triangles(
        o3d.core.Tensor(scene.mesh.vertices.astype(np.float32)),
        o3d.core.Tensor(scene.mesh.faces.astype(np.uint32)),
    )
    distance = raycaster.compute_distance(o3d.core.Tensor(scan.points_m.astype(np.float32)))
    assert distance.numpy().max() < 0.0001


def _groove_edges(mesh, point, axis, across, half_span_m=0.02, step_m=0.00001):
    """Offsets (along `across`) of the two groove edges around `point` at surface level,
    found by rays along the torch axis `axis` starting 2 mm above the surface."""
    offsets = np.arange(-half_span_m, half_span_m + step_m / 2, step_m)
    origins = point + offsets[:, None] * across - 0.002 * axis
    t_hit, _ = cast_rays(mesh, origins, np.broadcast_to(axis, origins.shape))
    below = t_hit > 0.002 + 1e-5
    centre = len(offsets) // 2
    assert below[centre] and not below[0] and not below[-1]
    left = np.nonzero(~below[:centre])[0].max()
    right = centre + np.nonzero(~below[centre:])[0].min()
    return offsets[left] + step_m / 2, offsets[right] - step_m / 2, t_hit[[0, -1]]


@pytest.mark.parametrize(
    "family", ["v_butt", "curved_groove", "ring_groove", "pipe_groove", "block_groove",
               "inclined_plates", "two_grooves", "y_groove"],
)
def test_v_groove_truth_is_midway_between_the_edges_at_surface_level(family):
    rng = np.random.default_rng(9)
    scenes = [FAMILIES[family](rng)]
    if family == "curved_groove":
        scenes = [curved_groove(rng, shape="arc"), curved_groove(rng, shape="s_curve")]
    for scene in scenes:
        for seam in scene.seams:
            points = seam.points_m
            # Stay away from seam ends, the Y junction and the block's bends.
            for k in np.linspace(0.2, 0.8, 4) * (len(points) - 1):
                k = int(k)
                tangent = unit(points[k + 1] - points[k - 1])
                axis = seam.torch_axes[k]
                if family == "block_groove" and not np.allclose(seam.torch_axes[k - 40],
                                                                seam.torch_axes[k + 40]):
                    continue
                across = unit(np.cross(tangent, axis))
                left, right, surface_t = _groove_edges(scene.mesh, points[k], axis, across)
                assert (left + right) / 2 == pytest.approx(0.0, abs=2e-5)
                assert right - left > 0.004
                assert surface_t == pytest.approx(0.002, abs=1e-6)  # truth at surface level


def test_fillet_truth_lies_in_the_corner_with_a_bisecting_torch_axis():
    rng = np.random.default_rng(10)
    scene = fillet_t(rng)
    for seam in scene.seams:
        assert np.allclose(np.abs(seam.torch_axes[:, 2]), np.sqrt(0.5))
        starts = seam.points_m[::50] - 0.003 * seam.torch_axes[::50]
        t_hit, _ = cast_rays(scene.mesh, starts, seam.torch_axes[::50])
        assert np.allclose(t_hit, 0.003, atol=1e-6)


def test_fillet_camera_sees_the_near_corner_only():
    rng = np.random.default_rng(11)
    scene = fillet_t(rng, side=1.0, yaw_deg=0.0)
    scan = make_scan(scene, rng)
    near = [k for k, s in enumerate(scene.seams) if s.points_m[0, 1] > 0]
    assert len(near) == 1
    assert scan.visible[near[0]].mean() > 0.8
    assert not scan.visible[1 - near[0]].any()


def test_visible_mask_honours_occlusion_and_viewing_angle():
    rng = np.random.default_rng(12)
    scene = v_butt(rng, yaw_deg=0.0)
    seam = scene.seams[0]
    above = look_at(scene.camera_target_m + [0, 0, 0.45], scene.camera_target_m, up=(0, 1, 0))
    assert visible_mask(scene, seam, above).all()
    below = look_at(scene.camera_target_m - [0, 0, 0.45], scene.camera_target_m, up=(0, 1, 0))
    assert not visible_mask(scene, seam, below).any()  # the table is in the way
    grazing = look_at(scene.camera_target_m + [0.45, 0, 0.1], scene.camera_target_m)
    assert not visible_mask(scene, seam, grazing).any()  # 77 deg from the torch axis


def test_a_seam_inside_a_sensor_hole_is_not_observed():
    """Where the sensor returned no depth around a truth point's pixel (a hole blob), the scan
    holds nothing of the seam there: it does not count as seen, whatever the mesh shows."""
    rng = np.random.default_rng(12)
    scene = v_butt(rng, yaw_deg=0.0)
    seam = scene.seams[0]
    scan = make_scan(scene, rng, SensorNoise.clean())
    assert scan.visible[0].mean() > 0.9
    middle = seam.points_m[len(seam.points_m) // 2]
    col, row, _ = (int(round(v[0])) for v in pixel_of(middle[None], scan.T_base_camera, D415))
    holed = scan.depth.copy()
    holed[row - 15:row + 16, col - 15:col + 16] = 0
    returned = returned_mask(holed, seam, scan.T_base_camera, D415)
    lost = np.linalg.norm(seam.points_m - middle, axis=1) < 0.005
    assert lost.any() and not returned[lost].any()
    far = np.linalg.norm(seam.points_m - middle, axis=1) > 0.03
    assert returned[far & scan.visible[0]].all()


def test_block_groove_view_shows_the_top_and_one_side():
    rng = np.random.default_rng(13)
    scene = block_groove(rng, side=-1.0, yaw_deg=0.0)
    visible = make_scan(scene, rng).visible[0]
    axes = scene.seams[0].torch_axes
    assert visible[axes[:, 2] < -0.5].mean() > 0.8  # top run
    assert visible[axes[:, 0] > 0.5].mean() > 0.5  # the -x face, seen from the -x side
    assert not visible[axes[:, 0] < -0.5].any()


def test_default_camera_distance_and_aim():
    rng = np.random.default_rng(14)
    scene = v_butt(rng)
    for _ in range(20):
        pose = default_camera(scene, rng)
        offset = scene.camera_target_m - pose[:3, 3]
        assert 0.35 <= np.linalg.norm(offset) <= 0.6
        assert np.allclose(pose[:3, 2], unit(offset))
        assert np.degrees(np.arccos(-pose[2, 2])) <= 30.0 + 1e-9
