import numpy as np

from weldseam.pipeline.condition import condition_points, sparse_points
from weldseam.pipeline.neighbours import radius_pairs


def test_invalid_points_go_and_each_voxel_becomes_its_centroid(rng):
    # Voxels are counted from the cloud's minimum corner (~0 here): two clusters well inside voxels 0 and 5.
    inside = rng.uniform(0.0, 0.0006, (50, 3))
    other = rng.uniform(0.0, 0.0006, (30, 3)) + [0.0052, 0.0, 0.0]
    invalid = np.array([[np.nan, 0.0, 0.0], [0.0, np.inf, 0.0], [0.0, 0.0, -np.inf]])
    fine = condition_points(np.vstack([inside, invalid, other]), voxel_m=0.001)
    assert len(fine) == 2
    expected = np.sort(np.stack([inside.mean(axis=0), other.mean(axis=0)]), axis=0)
    assert np.allclose(np.sort(fine, axis=0), expected, atol=1e-12)


def test_the_crop_box_keeps_only_the_points_inside_it(rng):
    points = rng.uniform(-0.1, 0.1, (5000, 3))
    fine = condition_points(points, voxel_m=0.001, crop_min_m=(-0.05, -0.05, -0.05), crop_max_m=(0.05, 0.05, 0.0))
    assert len(fine) > 0
    assert fine.min(axis=0).min() >= -0.05 and fine[:, :2].max() <= 0.05 and fine[:, 2].max() <= 0.0


def test_isolated_points_are_sparse_and_the_surface_is_not(rng):
    ticks = np.arange(0.0, 0.05, 0.0025)
    plane = np.column_stack([*(a.ravel() for a in np.meshgrid(ticks, ticks)), np.zeros(ticks.size**2)])
    strays = np.array([[0.025, 0.025, 0.03], [0.2, 0.2, 0.2]])  # a flying pixel above, an outlier far off
    points = np.vstack([plane, strays])
    sparse = sparse_points(radius_pairs(points, 0.006), len(points), min_fraction=0.25)
    assert sparse[-2:].all() and not sparse[:-2].any()
