"""The simulated D415: camera pose, noise level, and each artefact on its own."""

import dataclasses

import numpy as np
import pytest
import trimesh

from weldseam.geometry import transform_points
from weldseam.synthetic.sensor import D415, SensorNoise, look_at, render_depth, scan_points

FINE = dataclasses.replace(D415, depth_scale=1e5)  # 10 um depth units for sub-mm checks
OFF = SensorNoise.clean()


def _table():
    return trimesh.creation.box(bounds=[[-0.5, -0.5, -0.03], [0.5, 0.5, 0.0]])


def _down(height_m=0.45):
    return look_at([0.0, 0.0, height_m], [0.0, 0.0, 0.0], up=(0.0, 1.0, 0.0))


def test_look_at_points_the_optical_axis_at_the_target_with_image_y_down():
    eye, target = np.array([0.3, -0.2, 0.5]), np.array([0.05, 0.02, 0.01])
    pose = look_at(eye, target)
    rotation = pose[:3, :3]
    assert np.allclose(rotation.T @ rotation, np.eye(3))
    assert np.isclose(np.linalg.det(rotation), 1.0)
    assert np.allclose(rotation[:, 2], (target - eye) / np.linalg.norm(target - eye))
    local = transform_points(np.linalg.inv(pose), np.array([target, target + [0, 0, 0.05]]))
    assert np.allclose(local[0, :2], 0.0, atol=1e-12)
    assert local[1, 1] < 0  # higher in the world = higher in the image (y points down)


def test_look_at_straight_down_falls_back_to_another_up_vector():
    pose = look_at([0, 0, 0.4], [0, 0, 0])
    assert np.allclose(pose[:3, :3].T @ pose[:3, :3], np.eye(3))
    assert np.allclose(pose[:3, 2], [0, 0, -1])


def test_axial_noise_is_half_a_millimetre_at_045_m():
    noise = dataclasses.replace(OFF, subpixel_px=0.08)
    depth = render_depth(_table(), _down(0.45), FINE, np.random.default_rng(0), noise)
    points = scan_points(depth, FINE, _down(0.45))
    design = np.column_stack([points[:, :2], np.ones(len(points))])
    residual = points[:, 2] - design @ np.linalg.lstsq(design, points[:, 2], rcond=None)[0]
    expected = noise.axial_sigma_m(0.45, D415.fx)
    assert expected == pytest.approx(0.45**2 * 0.08 / (619.97 * 0.055))
    assert residual.std() == pytest.approx(0.0005, rel=0.10)
    assert residual.std() == pytest.approx(expected, rel=0.03)


def test_clean_render_is_exact_and_quantisation_rounds_to_the_step():
    rng = np.random.default_rng(0)
    depth = render_depth(_table(), _down(0.4567), FINE, rng, OFF)
    assert np.all(depth == 45670)
    coarse = render_depth(_table(), _down(0.4567), FINE, rng, SensorNoise.clean(0.001))
    assert np.all(coarse == 45700)


def test_holes_cover_a_few_percent_in_a_few_blobs():
    from scipy.ndimage import label

    noise = dataclasses.replace(OFF, hole_fraction=0.03, hole_count=5)
    depth = render_depth(_table(), _down(), D415, np.random.default_rng(3), noise)
    missing = depth == 0
    assert 0.015 < missing.mean() < 0.05
    assert 1 <= label(missing)[1] <= 15


def test_outliers_replace_that_many_pixels():
    noise = dataclasses.replace(OFF, outlier_count=300)
    depth = render_depth(_table(), _down(), FINE, np.random.default_rng(4), noise)
    moved = np.abs(depth.astype(float) - 45000) > 500  # more than 5 mm off
    assert 250 <= moved.sum() <= 300


def test_flying_pixels_only_at_depth_edges_and_between_the_two_depths():
    step = trimesh.util.concatenate(
        [_table(), trimesh.creation.box(bounds=[[0.0, -0.5, 0.0], [0.5, 0.5, 0.02]])]
    )
    noise = dataclasses.replace(OFF, flying_pixel_probability=1.0)
    depth = render_depth(step, _down(), FINE, np.random.default_rng(5), noise).astype(float)
    clean = render_depth(step, _down(), FINE, np.random.default_rng(5), OFF).astype(float)
    flying = depth != clean
    assert flying.sum() > 100
    rows, cols = np.nonzero(flying)
    near, far = clean.min(), clean.max()
    assert near == pytest.approx(43000, abs=1) and far == pytest.approx(45000, abs=1)
    assert np.all((depth[flying] >= near) & (depth[flying] <= far))
    edge_cols = np.nonzero(np.any(np.diff(clean, axis=1) != 0, axis=0))[0]
    assert np.all(np.abs(cols[:, None] - edge_cols[None]).min(axis=1) <= 1)


def test_no_return_at_grazing_incidence():
    normal = np.array([np.sin(np.radians(70)), 0.0, np.cos(np.radians(70))])
    corners = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]) * 0.3
    tilted = trimesh.Trimesh(corners @ trimesh.transformations.rotation_matrix(
        np.radians(70), [0, 1, 0])[:3, :3].T, [[0, 1, 2], [0, 2, 3]])
    pose = _down()

    def incidence_deg(noise):
        depth = render_depth(tilted, pose, D415, np.random.default_rng(6), noise)
        rays = scan_points(depth, D415, pose) - pose[:3, 3]
        cosines = np.abs(rays @ normal) / np.linalg.norm(rays, axis=1)
        return np.degrees(np.arccos(cosines))

    assert np.any(incidence_deg(OFF) > 77)
    kept = incidence_deg(dataclasses.replace(OFF, max_incidence_deg=75.0))
    assert len(kept) > 1000 and kept.max() < 75.2


def _box_on_table(half_m=0.05, height_m=0.05):
    box = trimesh.creation.box(bounds=[[-half_m, -half_m, 0.0], [half_m, half_m, height_m]])
    return trimesh.util.concatenate([_table(), box])


def test_ripple_is_smooth_and_peaks_at_its_amplitude():
    noise = dataclasses.replace(OFF, ripple_amplitude_m=0.0002)
    depth = render_depth(_table(), _down(0.45), FINE, np.random.default_rng(20), noise)
    ripple_m = depth.astype(float) / FINE.depth_scale - 0.45
    assert np.abs(ripple_m).max() == pytest.approx(0.0002, abs=1e-5)
    assert ripple_m.std() > 0.00004
    # Low frequency: one pixel further the ripple moves by at most 2 pi A / 60 px * 3 waves.
    assert np.abs(np.diff(ripple_m, axis=1)).max() <= 3 * 2 * np.pi * 0.0002 / 60 + 1e-5
    other = render_depth(_table(), _down(0.45), FINE, np.random.default_rng(21), noise)
    assert not np.array_equal(depth, other)  # a new pattern per scan


@pytest.mark.parametrize("side", [-1, 1])
def test_stereo_shadow_hides_what_the_second_imager_cannot_see(side):
    mesh, pose = _box_on_table(), _down(0.45)
    clean = render_depth(mesh, pose, FINE, np.random.default_rng(0), OFF)
    noise = dataclasses.replace(OFF, stereo_shadow_side=side)
    shadowed = render_depth(mesh, pose, FINE, np.random.default_rng(0), noise)
    assert np.all(shadowed[shadowed > 0] == clean[shadowed > 0])
    lost = (clean > 0) & (shadowed == 0)
    # Independent answer: a table point is shadowed when the segment from it to the second
    # imager (baseline along the camera's x axis, here base +x) passes through the box
    # (slab test against |x|, |y| < 50 mm, 0 < z < 50 mm).
    points = scan_points(clean, FINE, pose)
    second = pose[:3, 3] + side * 0.055 * pose[:3, 0]
    step = second - points
    low, high = np.array([-0.05, -0.05, 1e-6]), np.array([0.05, 0.05, 0.05 - 1e-6])
    with np.errstate(divide="ignore", invalid="ignore"):
        t_low, t_high = (low - points) / step, (high - points) / step
    enter = np.nanmax(np.minimum(t_low, t_high), axis=1)
    leave = np.nanmin(np.maximum(t_low, t_high), axis=1)
    expected = np.zeros(clean.shape, dtype=bool)
    expected[clean > 0] = (enter < leave) & (leave > 0) & (enter < 1)
    assert 1000 < expected.sum() < 10000
    assert (lost != expected).sum() <= 0.02 * expected.sum()  # pixels on the strip's edge
    # The strip lies beside the box on the side away from the second imager.
    x_lost = scan_points(np.where(lost, clean, 0), FINE, pose)[:, 0]
    assert np.all(-side * x_lost > 0.05 - 1e-3)


def test_incidence_jitter_makes_the_limit_ragged():
    from scipy.special import ndtr

    corners = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]) * 0.3
    # One plane seen from a slant: incidence angles from 56 to 83 deg across the image.
    tilted = trimesh.Trimesh(corners @ trimesh.transformations.rotation_matrix(
        np.radians(78), [0, 1, 0])[:3, :3].T, [[0, 1, 2], [0, 2, 3]])
    normal = np.array([np.sin(np.radians(78)), 0.0, np.cos(np.radians(78))])
    pose = _down()
    clean = render_depth(tilted, pose, D415, np.random.default_rng(6), OFF)
    rays = scan_points(clean, D415, pose) - pose[:3, 3]
    angles = np.degrees(np.arccos(np.abs(rays @ normal) / np.linalg.norm(rays, axis=1)))
    noise = dataclasses.replace(OFF, max_incidence_deg=75.0, incidence_jitter_deg=2.0)
    kept = render_depth(tilted, pose, D415, np.random.default_rng(6), noise)[clean > 0] > 0
    # Kept where 75 + 2 Z > angle, Z standard normal: probability ndtr((75 - angle) / 2).
    for low in range(69, 82, 2):
        band = (angles >= low) & (angles < low + 2)
        assert band.sum() > 1000
        assert kept[band].mean() == pytest.approx(ndtr((75.0 - angles[band]) / 2.0).mean(), abs=0.02)
    assert kept[angles < 65.0].all()  # 5 sigma


def test_hires_profile_noise_and_depth_steps():
    from weldseam.synthetic.sensor import HIRES

    rng = np.random.default_rng(30)
    noise = dataclasses.replace(SensorNoise.hires(rng), ripple_amplitude_m=0.0, hole_fraction=0.0,
                                outlier_count=0, flying_pixel_probability=0.0)
    assert (HIRES.width, HIRES.height, HIRES.depth_scale) == (1944, 1200, 10000.0)
    assert noise.axial_sigma_m(0.45, HIRES.fx) == pytest.approx(0.00007, rel=0.02)
    assert noise.quantisation_m == 0.0001
    depth = render_depth(_table(), _down(0.45), HIRES, rng, noise)
    points = scan_points(depth, HIRES, _down(0.45))
    assert len(points) == HIRES.width * HIRES.height
    assert points[:, 2].std() == pytest.approx(0.00007, rel=0.1)
    clean = render_depth(_table(), _down(0.45678), HIRES, rng, SensorNoise.clean(0.0001))
    assert np.all(clean == 4568)  # 0.45678 m rounded to the 0.1 mm step
