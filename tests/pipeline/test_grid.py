import numpy as np

from weldseam.pipeline.grid import voxel_centroids, voxel_grid


def test_points_in_one_leaf_merge_to_their_centroid_and_leaves_apart_stay_apart(rng):
    leaf = 0.003
    centres = np.array([[0.0015, 0.0015, 0.0015], [0.0105, 0.0015, 0.0015], [0.0015, 0.0075, 0.0045]])
    clouds = [c + rng.uniform(-0.0014, 0.0014, (20, 3)) for c in centres]
    merged = voxel_centroids(np.vstack(clouds), leaf)
    expected = np.array([cloud.mean(axis=0) for cloud in clouds])
    assert len(merged) == 3
    assert np.allclose(np.sort(merged, axis=0), np.sort(expected, axis=0), atol=1e-12)


def test_the_grid_does_not_depend_on_the_order_of_the_points(rng):
    points = rng.uniform(0, 0.05, (2000, 3))
    once = voxel_centroids(points, 0.003)
    shuffled = voxel_centroids(points[rng.permutation(len(points))], 0.003)
    assert np.allclose(once, shuffled, atol=1e-15)


def test_each_point_s_voxel_index_is_that_of_its_centroid(rng):
    points = rng.uniform(0.0, 0.1, (30_000, 3))  # voxel_centroids on both cores, voxel_grid on one
    centroids, index = voxel_grid(points, 0.008)
    assert np.array_equal(centroids, voxel_centroids(points, 0.008))  # to the bit
    assert index.shape == (len(points),) and index.max() == len(centroids) - 1
    for voxel in (0, len(centroids) // 2, len(centroids) - 1):
        assert np.allclose(centroids[voxel], points[index == voxel].mean(axis=0))
