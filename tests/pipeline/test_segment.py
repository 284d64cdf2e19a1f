import numpy as np

from tests.test_pipeline_helpers import crease_points
from weldseam.pipeline.descriptor import gradient_descriptor
from weldseam.pipeline.neighbours import radius_graph
from weldseam.pipeline.normals import estimate_normals
from weldseam.pipeline.segment import automatic_threshold, cluster_candidates, dense_selection, noise_floor

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
