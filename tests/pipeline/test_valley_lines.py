import numpy as np

from tests.conftest import rotation_about
from weldseam.pipeline.descriptor import valley_depth
from weldseam.pipeline.neighbours import centroid_offsets, radius_graph
from weldseam.pipeline.normals import estimate_normals
from weldseam.pipeline.segment import automatic_threshold, dense_selection, noise_floor, wide_valleys
from weldseam.pipeline.valley_lines import band_width_m, line_valley_depth, valley_directions

SPACING = 0.0025
RADIUS = 0.006
CAMERA = np.array([0.0, 0.0, 0.5])


def tube_valley(rng, *, included_deg=130.0, tube_radius_m=0.04, rounding_m=0.005, noise_m=0.0002):
    """A 120 x 120 mm sheet at SPACING: two tubes' tops (radius `tube_radius_m`) meeting along y at
    `included_deg`, the valley rounded over `rounding_m`, in `noise_m` of noise; its points and
    their distance (m) across the valley line."""
    ticks = np.arange(-0.06, 0.06, SPACING)
    u, v = (grid.ravel() for grid in np.meshgrid(ticks, ticks, indexing="ij"))
    slope = np.tan(np.radians((180.0 - included_deg) / 2))
    height = slope * np.sqrt(u * u + rounding_m**2) - u * u / (2 * tube_radius_m)
    return np.column_stack([u, v, height + rng.normal(0.0, noise_m, len(u))]), np.abs(u)


def depth_and_normals(points, camera=CAMERA):
    graph = radius_graph(points, RADIUS)
    normals = estimate_normals(points, graph, camera_origin_m=camera)
    return valley_depth(centroid_offsets(graph, points), normals), normals, graph


def threshold(min_crease_deg):
    return automatic_threshold(spacing_m=SPACING, normals_radius_m=RADIUS, descriptor_radius_m=RADIUS,
                               variant="valley", min_crease_deg=min_crease_deg)  # fmt: skip


def test_the_direction_runs_along_the_valley_in_any_frame(rng):
    points, across = tube_valley(rng)
    _, normals, _ = depth_and_normals(points)
    near = across < 0.005
    assert np.abs(valley_directions(points, normals)[near, 1]).min() > 0.95
    turn = rotation_about([1.0, 2.0, 0.5], np.radians(70.0))  # a frame that is not z-up
    rotated, camera = points @ turn.T, turn @ CAMERA
    _, normals, _ = depth_and_normals(rotated, camera)
    assert np.abs(valley_directions(rotated, normals)[near] @ (turn @ [0.0, 1.0, 0.0])).min() > 0.95


def test_a_valley_between_tubes_too_shallow_for_both_radii_stands_out_along_its_length():
    """Over the fine radius the valley is lost in the noise, over the wide one the tubes' own bend
    cancels it; averaged along its own direction it stands out along its length, and only there."""
    for seed in range(3):
        points, across = tube_valley(np.random.default_rng(seed))
        depth, normals, graph = depth_and_normals(points)
        fine = dense_selection(graph, depth > max(threshold(20.0), noise_floor(depth, 2.0)), 0.25)
        wide = wide_valleys(points, CAMERA, radius_m=0.02, min_crease_deg=20, noise_factor=2.0, min_density=0.25)
        near = across < 0.002
        assert fine[near].mean() < 0.1 and not wide[across < 0.005].any()
        line = line_valley_depth(points, normals, depth, spacing_m=SPACING, length_m=0.03) > threshold(6.5)
        assert line[near].mean() > 0.5 and np.ptp(points[line & near, 1]) > 0.09  # of its 120 mm
        assert line[across > 0.01].mean() < 0.02


def test_a_line_is_averaged_only_where_half_its_samples_meet_the_surface():
    """A V along y, 10 mm long (4 rows): a 30 mm line along it meets the surface at 4 of its 13
    samples, a 5 mm one at 3 of 3 or 2 of 3 and averages the depths it meets."""
    u, v = (grid.ravel() * SPACING for grid in np.meshgrid(np.arange(-8, 8), np.arange(0, 4)))
    points = np.column_stack([u, v + np.where(v > 0, 0.2 * SPACING, 0.0), np.abs(u) * 0.3])  # off the voxels' faces
    normals = np.column_stack([-0.3 * np.sign(u), np.zeros_like(u), np.ones_like(u)])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    depth = 0.001 * (1.0 + v / SPACING)  # 1, 2, 3, 4 mm by row: which points are met shows
    assert not line_valley_depth(points, normals, depth, spacing_m=SPACING, length_m=0.03).any()
    mean = line_valley_depth(points, normals, depth, spacing_m=SPACING, length_m=0.005)
    rows = np.rint(v[u == 0] / SPACING)
    assert np.allclose(mean[u == 0], np.select([rows == 0, rows == 3], [0.0015, 0.0035], 0.002 + 0.001 * (rows - 1)))


def test_a_plane_without_noise_bends_nowhere_and_has_no_valley_in_any_frame():
    u, v = (grid.ravel() for grid in np.meshgrid(np.arange(0.0, 0.05, SPACING), np.arange(0.0, 0.05, SPACING)))
    points = np.column_stack([u, v, np.zeros_like(u)])
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    for turn in (np.eye(3), rotation_about([1.0, 2.0, 0.5], 1.0)):
        assert not line_valley_depth(points @ turn.T, normals @ turn.T, np.full(len(points), 0.001),
                                     spacing_m=SPACING, length_m=0.03).any()  # fmt: skip
    assert not line_valley_depth(np.empty((0, 3)), np.empty((0, 3)), np.empty(0), spacing_m=SPACING, length_m=0.03).size


def test_a_bands_width_is_its_area_over_its_length():
    u, v = (grid.ravel() for grid in np.meshgrid(np.arange(0.0, 0.1, SPACING), np.arange(0.0, 0.01, SPACING)))
    strip = np.column_stack([u, v, np.zeros_like(u)])
    assert abs(band_width_m(strip, SPACING) - 0.01) < 0.001
    assert abs(band_width_m(strip @ rotation_about([1.0, 1.0, 1.0], 1.0).T, SPACING) - 0.01) < 0.001
