import numpy as np
from scipy.spatial import cKDTree

from tests.test_pipeline_helpers import crease_points
from weldseam.config import SegmentConfig
from weldseam.pipeline.descriptor import gradient_descriptor, valley_depth
from weldseam.pipeline.neighbours import centroid_offsets, radius_graph
from weldseam.pipeline.normals import estimate_normals
from weldseam.pipeline.segment import (
    automatic_threshold, band_points, cluster_candidates, covered, dense_selection, noise_floor, uncovered, wide_valleys,
)

SPACING = 0.0025
RADIUS = 0.006


def descriptor_of(points):
    graph = radius_graph(points, RADIUS)
    normals = estimate_normals(points, graph, camera_origin_m=np.array([0, 0, 1.0]))
    return gradient_descriptor(normals, graph)


def test_automatic_threshold_selects_a_real_crease_and_not_noise(rng):
    threshold = automatic_threshold(
        spacing_m=SPACING, normals_radius_m=RADIUS, descriptor_radius_m=RADIUS, variant="released", min_crease_deg=20
    )
    strong = crease_points(35, SPACING)
    assert (descriptor_of(strong)[np.abs(strong[:, 0]) < 0.003] > threshold).all()
    weak = crease_points(8, SPACING)
    assert not (descriptor_of(weak) > threshold).any()
    noisy_plane = crease_points(0, SPACING) + rng.normal(0, 0.0003, (len(strong), 3)) * [0, 0, 1]
    assert (descriptor_of(noisy_plane) > threshold).mean() < 0.01


def test_clusters_split_far_apart_regions_and_drop_short_ones():
    line_a = np.column_stack([np.arange(0, 0.1, 0.002), np.zeros(50), np.zeros(50)])
    line_b = line_a + [0, 0.05, 0]
    speck = np.array([[0.2, 0.2, 0.0], [0.201, 0.2, 0.0]])
    points = np.vstack([line_a, line_b, speck])
    clusters, _ = cluster_candidates(points, np.ones(len(points), bool), tolerance_m=0.006, min_length_m=0.02)
    assert sorted(len(c) for c in clusters) == [50, 50]
    assert {tuple(np.unique(points[c][:, 1].round(3))) for c in clusters} == {(0.0,), (0.05,)}


def test_a_dense_band_is_kept_and_scattered_points_are_not(rng):
    ticks = np.arange(0.0, 0.1, 0.0025)
    x, y = (a.ravel() for a in np.meshgrid(ticks, ticks))
    points = np.column_stack([x, y, np.zeros(x.size)])
    band = np.abs(y - 0.05) < 0.004  # three rows: a crease
    speckle = rng.random(len(points)) < 0.03  # noise above the threshold here and there
    selected = band | speckle
    kept = dense_selection(radius_graph(points, 0.006), selected, 0.25)
    assert kept[band].mean() > 0.95
    assert kept[speckle & ~band & (np.abs(y - 0.05) > 0.01)].mean() < 0.05


def test_the_noise_floor_is_the_robust_sigma_times_the_factor(rng):
    values = rng.normal(0.0, 0.0002, 100_000)
    values[:500] = 0.01  # a few creases do not move it
    assert abs(noise_floor(values, 2.0) - 0.0004) < 0.00001


def rippled_valley(rng, included_deg):
    """A 120 x 120 mm sheet at SPACING: two faces meeting along y at `included_deg`, the valley
    rounded over 10 mm, with a sensor's 1 mm ripple (8-20 mm waves) and 0.3 mm noise; its points
    and their distance (m) across the valley line."""
    ticks = np.arange(-0.06, 0.06, SPACING)
    u, v = (grid.ravel() for grid in np.meshgrid(ticks, ticks, indexing="ij"))
    slope = np.tan(np.radians((180.0 - included_deg) / 2))
    height = slope * np.sqrt(u * u + 0.01**2)
    for wave_m, amplitude_m in ((0.02, 0.0006), (0.013, 0.0005), (0.008, 0.0003)):
        angle = rng.uniform(0, np.pi)
        height += amplitude_m * np.sin((u * np.cos(angle) + v * np.sin(angle)) * 2 * np.pi / wave_m + rng.uniform(0, 6.3))
    height += rng.normal(0, 0.0003, len(u))
    return np.column_stack([u, v, height]), np.abs(u)


def test_a_shallow_rippled_valley_is_found_over_the_wide_radius_not_the_fine_one(rng):
    """A 140-degree valley between two curved parts, rounded and in 1 mm ripple: over the fine
    radius its depth is lost in the ripple (scattered picks all over the sheet), over the wide
    radius it stands out along its whole length, on its line."""
    points, across = rippled_valley(rng, 140.0)
    camera = np.array([0.0, 0.0, 0.5])
    graph = radius_graph(points, RADIUS)
    depth = valley_depth(centroid_offsets(graph, points), estimate_normals(points, graph, camera_origin_m=camera))
    fine = depth > max(automatic_threshold(spacing_m=SPACING, normals_radius_m=RADIUS, descriptor_radius_m=RADIUS,
                                           variant="valley", min_crease_deg=20), noise_floor(depth, 2.0))
    fine = dense_selection(graph, fine, 0.25)
    wide = wide_valleys(points, camera, radius_m=0.02, min_crease_deg=20, noise_factor=2.0, min_density=0.25)
    on_line = points[wide & (across < 0.012)]
    assert np.ptp(on_line[:, 1]) > 0.09  # along the valley's 120 mm, less its ends
    assert (across[wide] < 0.012).mean() > 0.9  # a band two 8 mm voxels wide
    assert fine.sum() < 0.2 * wide.sum()


def test_no_wide_valley_on_a_rippled_plate(rng):
    points, _ = rippled_valley(rng, 180.0)
    assert not wide_valleys(points, np.array([0.0, 0.0, 0.5]), radius_m=0.02, min_crease_deg=20, noise_factor=2.0,
                            min_density=0.25).any()


def test_a_wide_valley_is_covered_by_one_fine_crease_along_it_not_by_pieces_beside_it():
    along = np.arange(0.0, 0.1, 0.0025)
    line = np.column_stack([along, np.zeros_like(along), np.zeros_like(along)])
    points = np.vstack([line, line + [0.0, 0.004, 0.0], line + [0.0, 0.02, 0.0]])
    wide = np.arange(len(along))
    crease_on_it, crease_aside = wide + len(along), wide + 2 * len(along)

    def trees(*creases):
        return [cKDTree(points[crease]) for crease in creases]

    assert covered(points[wide], trees(crease_aside, crease_on_it), tolerance_m=0.006)
    assert not covered(points[wide], trees(crease_aside), tolerance_m=0.006)
    pieces = [crease_on_it[k : k + 10] for k in range(0, len(along), 10)]  # four pieces, each a quarter
    assert not covered(points[wide], trees(*pieces), tolerance_m=0.006)


def test_a_cluster_another_pass_found_is_not_sought_again():
    along = np.arange(0.0, 0.1, 0.0025)
    line = np.column_stack([along, np.zeros_like(along), np.zeros_like(along)])
    points = np.vstack([line, line + [0.0, 0.003, 0.0], line + [0.0, 0.05, 0.0]])
    first, beside, apart = (np.arange(len(along)) + k * len(along) for k in range(3))
    kept = uncovered(points, [beside, apart], [first], tolerance_m=0.006)
    assert len(kept) == 1 and np.array_equal(kept[0], apart)
    assert len(uncovered(points, [beside, apart], [], tolerance_m=0.006)) == 2


def test_a_wide_valleys_band_is_merged_into_voxels_a_quarter_of_its_radius(rng):
    band = rng.uniform([0.0, -0.01, 0.0], [0.06, 0.01, 0.001], (2000, 3))
    merged = band_points(band, SegmentConfig())
    assert 10 < len(merged) < 200 and np.abs(merged[:, 1]).max() < 0.01
