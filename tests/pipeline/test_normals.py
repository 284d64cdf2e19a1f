import numpy as np

from tests.conftest import rotation_about
from weldseam.pipeline.neighbours import radius_graph
from weldseam.pipeline.normals import estimate_normals


def test_plane_normals_match_the_plane_and_face_the_camera(rng):
    grid = np.stack(np.meshgrid(np.arange(0, 0.1, 0.002), np.arange(0, 0.1, 0.002)), -1).reshape(-1, 2)
    rotation = rotation_about([1, 2, 0.5], 0.7)
    points = np.column_stack([grid, rng.normal(0, 1e-4, len(grid))]) @ rotation.T
    true_normal = rotation[:, 2]
    camera = points.mean(axis=0) - 0.5 * true_normal  # camera on the -normal side
    normals = estimate_normals(points, radius_graph(points, 0.01), camera_origin_m=camera)
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    angle = np.degrees(np.arccos(np.clip(normals @ -true_normal, -1, 1)))
    assert np.median(angle) < 0.5
    assert angle.max() < 3.0
