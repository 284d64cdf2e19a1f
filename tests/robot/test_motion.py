import numpy as np
from scipy.spatial.transform import Rotation

from weldseam.robot.motion import pose_matrices, pose_vectors


def test_pose_vectors_round_trip_and_keep_angles_within_pi():
    rng = np.random.default_rng(0)
    rotvecs = Rotation.random(200, random_state=1).as_rotvec()
    vectors = np.concatenate([rng.uniform(-1, 1, (200, 3)), rotvecs], axis=1)
    again = pose_vectors(pose_matrices(vectors))
    assert np.allclose(pose_matrices(again), pose_matrices(vectors), atol=1e-12)
    assert np.all(np.linalg.norm(again[:, 3:], axis=1) <= np.pi + 1e-12)


def test_pose_matrix_places_the_point_and_turns_the_axes():
    matrix = pose_matrices(np.array([0.1, 0.2, 0.3, 0.0, 0.0, np.pi / 2]))
    assert np.allclose(matrix[:3, 3], [0.1, 0.2, 0.3])
    assert np.allclose(matrix[:3, 0], [0.0, 1.0, 0.0])
