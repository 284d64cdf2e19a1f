"""Fixed-radius neighbourhoods as sparse matrices, built once per cloud and reused."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree


def radius_graph(points: np.ndarray, radius_m: float) -> sparse.csr_matrix:
    """Symmetric 0/1 matrix (N, N): entry (i, j) = 1 when |p_i - p_j| <= radius_m, self included.

    Column indices within a row are in no particular order (but the same for the same input).
    """
    n = len(points)
    pairs = cKDTree(points, balanced_tree=False).query_pairs(radius_m, output_type="ndarray")
    self_index = np.arange(n)
    rows = np.concatenate([pairs[:, 0], pairs[:, 1], self_index])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0], self_index])
    graph = sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    # query_pairs gives each pair once, so there are no duplicates to sum: skipping that pass (and
    # the per-row sort of column indices that comes with it) halves the build time.
    graph.has_canonical_format = True
    return graph.tocsr()


def neighbour_mean(graph: sparse.csr_matrix, values: np.ndarray) -> np.ndarray:
    """Mean of `values` (N,) or (N, k) over each point's neighbourhood (rows of `graph`)."""
    counts = np.asarray(graph.sum(axis=1)).ravel()
    sums = graph @ values
    return sums / (counts if sums.ndim == 1 else counts[:, None])


def neighbour_variance(graph: sparse.csr_matrix, values: np.ndarray) -> np.ndarray:
    """Variance of the scalar `values` (N,) over each neighbourhood: E[v^2] - E[v]^2."""
    means = neighbour_mean(graph, np.column_stack([values, values * values]))
    return np.maximum(means[:, 1] - means[:, 0] ** 2, 0.0)


def graph_pairs(graph: sparse.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) index arrays of the graph's entries, rows ascending."""
    rows = np.repeat(np.arange(graph.shape[0]), np.diff(graph.indptr))
    return rows, graph.indices


def neighbour_covariance(points: np.ndarray, graph: sparse.csr_matrix) -> np.ndarray:
    """Covariance (N, 3, 3) of each point's neighbours (rows of `graph`)."""
    centred = points - points.mean(axis=0)
    x, y, z = centred.T
    moments = neighbour_mean(graph, np.column_stack([x, y, z, x * x, y * y, z * z, x * y, x * z, y * z]))
    mean = moments[:, :3]
    cov = np.empty((len(points), 3, 3))
    for (a, b), column in zip(((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)), range(3, 9)):
        cov[:, a, b] = cov[:, b, a] = moments[:, column] - mean[:, a] * mean[:, b]
    return cov


def principal_directions(points: np.ndarray, graph: sparse.csr_matrix) -> np.ndarray:
    """Unit direction (N, 3) of largest spread of each point's neighbours (a line's tangent)."""
    return extreme_eigenvectors(neighbour_covariance(points, graph), largest=True)


def extreme_eigenvectors(cov: np.ndarray, largest: bool) -> np.ndarray:
    """Unit eigenvector (N, 3) of the largest or smallest eigenvalue of symmetric (N, 3, 3)
    matrices, in closed form (vectorised; LAPACK's batched eigh is ~10x slower here).

    Eigenvalues by the trigonometric solution of the characteristic cubic; the eigenvector
    is the longest cross product of two rows of (A - lambda I), which are orthogonal to it.
    Isotropic matrices (no preferred direction) give the z axis.
    """
    q = np.trace(cov, axis1=1, axis2=2) / 3
    off = cov[:, 0, 1] ** 2 + cov[:, 0, 2] ** 2 + cov[:, 1, 2] ** 2
    spread = np.sqrt(((cov[:, 0, 0] - q) ** 2 + (cov[:, 1, 1] - q) ** 2 + (cov[:, 2, 2] - q) ** 2 + 2 * off) / 6)
    safe = np.where(spread > 0, spread, 1.0)
    shifted = (cov - q[:, None, None] * np.eye(3)) / safe[:, None, None]
    half_det = np.clip(np.linalg.det(shifted) / 2, -1.0, 1.0)
    phi = np.arccos(half_det) / 3
    value = q + 2 * spread * (np.cos(phi) if largest else np.cos(phi + 2 * np.pi / 3))
    rows = cov - value[:, None, None] * np.eye(3)
    candidates = np.stack(
        [np.cross(rows[:, 0], rows[:, 1]), np.cross(rows[:, 0], rows[:, 2]), np.cross(rows[:, 1], rows[:, 2])], axis=1
    )
    lengths = np.linalg.norm(candidates, axis=2)
    best = np.argmax(lengths, axis=1)
    vectors = candidates[np.arange(len(cov)), best]
    norm = lengths[np.arange(len(cov)), best]
    result = np.divide(vectors, norm[:, None], out=np.zeros_like(vectors), where=norm[:, None] > 0)
    result[norm <= 0] = (0.0, 0.0, 1.0)
    return result
