import numpy as np

from weldseam.pipeline.neighbours import extreme_eigenvectors


def test_closed_form_eigenvectors_match_lapack():
    rng = np.random.default_rng(5)
    # Plane-like, line-like and generic spreads, as normals and tangents see them.
    scales = np.concatenate([rng.uniform(0.5, 2, (300, 3)) * [1, 1, 0.01], rng.uniform(0.5, 2, (300, 3)) * [1, 0.05, 0.05], rng.uniform(0.1, 2, (300, 3))])
    rotations = np.linalg.qr(rng.normal(size=(900, 3, 3)))[0]
    cov = np.einsum("nij,nj,nkj->nik", rotations, scales**2, rotations)
    values, vectors = np.linalg.eigh(cov)
    for largest, column in ((False, 0), (True, 2)):
        ours = extreme_eigenvectors(cov, largest=largest)
        assert np.allclose(np.linalg.norm(ours, axis=1), 1.0)
        agreement = np.abs(np.sum(ours * vectors[:, :, column], axis=1))
        separated = np.abs(values[:, column] - values[:, 1]) > 1e-3 * values[:, 2]
        assert np.all(agreement[separated] > 1 - 1e-6)


def test_isotropic_matrices_give_a_unit_vector():
    assert np.allclose(extreme_eigenvectors(np.tile(np.eye(3), (2, 1, 1)), largest=False), [[0, 0, 1]] * 2)
