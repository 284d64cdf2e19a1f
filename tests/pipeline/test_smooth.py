import numpy as np

from weldseam.pipeline.neighbours import radius_graph
from weldseam.pipeline.smooth import smooth_points


def crease(rng, noise_m):
    """Two faces meeting at a 90-degree crease along y (z = |x|), 1.2 mm grid, Gaussian noise in z."""
    ticks = np.arange(-0.03, 0.03, 0.0012)
    x, y = (a.ravel() for a in np.meshgrid(ticks, ticks))
    return np.column_stack([x, y, np.abs(x) + rng.normal(0, noise_m, x.size)])


def test_smoothing_removes_noise_on_the_faces_and_keeps_the_crease(rng):
    points = crease(rng, 0.0003)
    smoothed = smooth_points(points, radius_graph(points, 0.006), radius_m=0.006)
    face = np.abs(points[:, 0]) > 0.01
    error_before = np.abs(points[face, 2] - np.abs(points[face, 0])) / np.sqrt(2)  # distance to the face
    error_after = np.abs(smoothed[face, 2] - np.abs(smoothed[face, 0])) / np.sqrt(2)
    assert error_after.std() < 0.5 * error_before.std()
    at_crease = np.abs(smoothed[:, 0]) < 0.0012
    # The crease is kept: points on it stay within 0.5 mm of the fold (a blur would lift them ~1.5 mm).
    assert np.median(smoothed[at_crease, 2] - np.abs(smoothed[at_crease, 0])) < 0.0005


def test_a_noiseless_plane_is_left_where_it_is(rng):
    ticks = np.arange(0.0, 0.04, 0.0012)
    x, y = (a.ravel() for a in np.meshgrid(ticks, ticks))
    plane = np.column_stack([x, y, 0.2 * x])
    smoothed = smooth_points(plane, radius_graph(plane, 0.006), radius_m=0.006)
    assert np.abs(smoothed - plane).max() < 1e-6
