import numpy as np
import pytest
from scipy.spatial.distance import pdist, squareform

from weldseam.pipeline.neighbours import COVARIANCE_ENTRIES, SPLIT_MIN_POINTS, extreme_eigenvectors, radius_pairs


def test_closed_form_eigenvectors_match_lapack():
    rng = np.random.default_rng(5)
    # Plane-like, line-like and generic spreads, as normals and tangents see them.
    scales = np.concatenate([rng.uniform(0.5, 2, (300, 3)) * [1, 1, 0.01], rng.uniform(0.5, 2, (300, 3)) * [1, 0.05, 0.05], rng.uniform(0.1, 2, (300, 3))])
    rotations = np.linalg.qr(rng.normal(size=(900, 3, 3)))[0]
    cov = np.einsum("nij,nj,nkj->nik", rotations, scales**2, rotations)
    values, vectors = np.linalg.eigh(cov)
    rows, cols = np.array(COVARIANCE_ENTRIES).T
    for largest, column in ((False, 0), (True, 2)):
        ours = extreme_eigenvectors(cov[:, rows, cols], largest=largest)
        assert np.allclose(np.linalg.norm(ours, axis=1), 1.0)
        agreement = np.abs(np.sum(ours * vectors[:, :, column], axis=1))
        separated = np.abs(values[:, column] - values[:, 1]) > 1e-3 * values[:, 2]
        assert np.all(agreement[separated] > 1 - 1e-6)


def test_isotropic_matrices_give_a_unit_vector():
    identity = np.tile([1.0, 1.0, 1.0, 0.0, 0.0, 0.0], (2, 1))  # xx, yy, zz, xy, xz, yz
    assert np.allclose(extreme_eigenvectors(identity, largest=False), [[0, 0, 1]] * 2)


@pytest.mark.parametrize("count", [SPLIT_MIN_POINTS - 1, SPLIT_MIN_POINTS])
def test_radius_pairs_are_every_pair_within_the_radius_once_whether_or_not_the_cloud_is_cut(rng, count):
    # A plate 0.3 x 0.2 m with 1 mm noise, plus points exactly on the median cut (ties go above it).
    points = np.column_stack([rng.uniform(0, 0.3, count), rng.uniform(0, 0.2, count), rng.normal(0, 0.001, count)])
    points[:50, 0] = np.median(points[:, 0])
    radius = 0.004
    pairs = radius_pairs(points, radius)
    assert pairs.dtype == np.int32 and np.all(pairs[:, 0] < pairs[:, 1])
    # Brute force over a strip across the middle, where the cut falls: the same pairs, none twice.
    strip = np.flatnonzero(np.abs(points[:, 0] - 0.15) < 0.02)
    close = np.argwhere(np.triu(squareform(pdist(points[strip])) <= radius, 1))
    expected = {(int(strip[i]), int(strip[j])) for i, j in close}
    in_strip = np.isin(pairs, strip).all(axis=1)
    found = [tuple(pair) for pair in pairs[in_strip].tolist()]
    assert len(found) == len(set(found)) and set(found) == expected
    assert np.array_equal(radius_pairs(points, radius), pairs), "the same order every time"
