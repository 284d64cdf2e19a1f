"""Fixed-radius neighbourhoods as sparse matrices, built once per cloud and reused."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from weldseam.geometry import column_bounds
from weldseam.pipeline.parallel import MIN_BLOCK_ROWS, graph_rows, map_row_blocks, run_parts

# Clouds this large are searched for pairs on both cores (radius_pairs).
SPLIT_MIN_POINTS = 2 * MIN_BLOCK_ROWS
# Fewer queries are answered on one thread (query_workers).
THREADED_QUERIES = 2000
# The (row, column) of each of the six distinct entries of a symmetric 3 x 3 matrix, in the
# order they are passed around: xx, yy, zz, xy, xz, yz.
COVARIANCE_ENTRIES = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def radius_pairs(points: np.ndarray, radius_m: float) -> np.ndarray:
    """Index pairs (M, 2) int32 of the points within `radius_m` of each other, each unordered
    pair once (i < j), in an order fixed by the points (the same for the same input).

    A cloud of SPLIT_MIN_POINTS or more is cut across its longest axis at the median, and the
    search runs on both cores (cKDTree releases the GIL): the pairs within each half, each on
    its own thread, then those across the cut, among the points within radius_m of it. The cut
    depends on the points alone, so the pairs come in the same order on any machine.
    """
    if len(points) < SPLIT_MIN_POINTS:
        return _pairs_within(points, radius_m)
    low, high = column_bounds(points)
    along = points[:, int(np.argmax(high - low))]
    cut = np.median(along)
    below, above = np.flatnonzero(along < cut), np.flatnonzero(along >= cut)
    within = run_parts(lambda half: half.astype(np.int32)[_pairs_within(points[half], radius_m)], [below, above])
    # A pair across the cut lies within radius_m of it on both sides.
    near_below, near_above = below[along[below] >= cut - radius_m], above[along[above] <= cut + radius_m]
    across = cKDTree(points[near_below], balanced_tree=False).sparse_distance_matrix(
        cKDTree(points[near_above], balanced_tree=False), radius_m, output_type="ndarray"
    )
    ends = np.column_stack([near_below[across["i"]], near_above[across["j"]]]).astype(np.int32)
    return np.concatenate([*within, np.sort(ends, axis=1)])


def query_workers(count: int) -> int:
    """cKDTree's `workers` for `count` queries: both cores (-1) for THREADED_QUERIES or more, else
    this thread (1): it starts its threads anew for each call (~0.2 ms, more under load)."""
    return -1 if count >= THREADED_QUERIES else 1


def _pairs_within(points: np.ndarray, radius_m: float) -> np.ndarray:
    """radius_pairs by one search, in the tree's traversal order."""
    pairs = cKDTree(points, balanced_tree=False).query_pairs(radius_m, output_type="ndarray")
    return pairs.astype(np.int32)


def pairs_graph(pairs: np.ndarray, count: int) -> sparse.csr_matrix:
    """Symmetric 0/1 matrix (count, count) with an entry (i, j) and (j, i) for each of `pairs`
    (each unordered pair once) and each point with itself. Column indices within a row are in
    the order of `pairs`, then the point itself."""
    self_index = np.arange(count, dtype=np.int32)
    rows = np.concatenate([pairs[:, 0], pairs[:, 1], self_index])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0], self_index])
    graph = sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(count, count))
    # Each pair comes once, so there are no duplicates to sum: skipping that pass (and the
    # per-row sort of column indices that comes with it) halves the build time.
    graph.has_canonical_format = True
    return graph.tocsr()


def pairs_among(pairs: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """The pairs (M, 2) between points with `kept` (N,) true, in order, renumbered to index
    the kept points only (points[kept])."""
    index = np.cumsum(kept, dtype=np.int32) - 1
    # take and compress: a third of the time of fancy and boolean indexing on millions of pairs.
    return index.take(pairs.compress(kept.take(pairs[:, 0]) & kept.take(pairs[:, 1]), axis=0))


def radius_graph(points: np.ndarray, radius_m: float) -> sparse.csr_matrix:
    """Symmetric 0/1 matrix (N, N): entry (i, j) = 1 when |p_i - p_j| <= radius_m, self included.

    Column indices within a row are in no particular order (but the same for the same input).
    """
    return pairs_graph(radius_pairs(points, radius_m), len(points))


def neighbour_mean(graph: sparse.csr_matrix, values: np.ndarray) -> np.ndarray:
    """Mean of `values` (N,) or (N, k) over each point's neighbourhood (rows of the 0/1 `graph`)."""
    counts = np.diff(graph.indptr)
    sums = map_row_blocks(lambda rows: graph_rows(graph, rows) @ values, graph.shape[0])
    return sums / (counts if sums.ndim == 1 else counts[:, None])


def centroid_offsets(graph: sparse.csr_matrix, points: np.ndarray) -> np.ndarray:
    """(N, 3) offset (m) from each point to the centroid of its neighbours (rows of `graph`):
    mean_j p_j - p_i. The valley depth and the inward shift of a rim both start from it."""
    return neighbour_mean(graph, points) - points


def neighbour_variance(graph: sparse.csr_matrix, values: np.ndarray) -> np.ndarray:
    """Variance of the scalar `values` (N,) over each neighbourhood: E[v^2] - E[v]^2."""
    means = neighbour_mean(graph, np.column_stack([values, values * values]))
    return np.maximum(means[:, 1] - means[:, 0] ** 2, 0.0)


def graph_pairs(graph: sparse.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) index arrays of the graph's entries, rows ascending."""
    rows = np.repeat(np.arange(graph.shape[0]), np.diff(graph.indptr))
    return rows, graph.indices


def neighbour_covariance(points: np.ndarray, graph: sparse.csr_matrix) -> np.ndarray:
    """The six distinct entries (N, 6) of the covariance of each point's neighbours (rows of
    `graph`), in COVARIANCE_ENTRIES order: E[ab] - E[a] E[b]."""
    centred = points - points.mean(axis=0)
    x, y, z = centred.T
    moments = neighbour_mean(graph, np.column_stack([x, y, z, x * x, y * y, z * z, x * y, x * z, y * z]))
    first, second = np.array(COVARIANCE_ENTRIES).T
    return moments[:, 3:] - moments[:, first] * moments[:, second]


def principal_directions(points: np.ndarray, graph: sparse.csr_matrix) -> np.ndarray:
    """Unit direction (N, 3) of largest spread of each point's neighbours (a line's tangent)."""
    return extreme_eigenvectors(neighbour_covariance(points, graph), largest=True)


def extreme_eigenvectors(cov: np.ndarray, largest: bool) -> np.ndarray:
    """Unit eigenvector (N, 3) of the largest or smallest eigenvalue of symmetric 3 x 3
    matrices given by their six distinct entries (N, 6) in COVARIANCE_ENTRIES order, in
    closed form (LAPACK's batched eigh is ~10x slower here).

    Eigenvalues by the trigonometric solution of the characteristic cubic; the eigenvector
    is the longest cross product of two rows of (A - lambda I), which are orthogonal to it.
    Isotropic matrices (no preferred direction) give the z axis.
    """
    return map_row_blocks(lambda rows: _extreme_eigenvectors(cov[rows], largest), len(cov))


def _extreme_eigenvectors(cov: np.ndarray, largest: bool) -> np.ndarray:
    xx, yy, zz, xy, xz, yz = np.ascontiguousarray(cov.T)  # contiguous rows: the arithmetic is 20% faster
    q = (xx + yy + zz) / 3
    dx, dy, dz = xx - q, yy - q, zz - q
    off = xy * xy + xz * xz + yz * yz
    spread = np.sqrt((dx * dx + dy * dy + dz * dz + 2 * off) / 6)
    # det(A - qI) / spread^3, halved: cos(3 phi) of the trigonometric solution.
    det = dx * (dy * dz - yz * yz) - xy * (xy * dz - yz * xz) + xz * (xy * yz - dy * xz)
    with np.errstate(divide="ignore", invalid="ignore"):
        half_det = np.clip(np.where(spread > 0, det / (2 * spread**3), 0.0), -1.0, 1.0)
    phi = np.arccos(half_det) / 3
    value = q + 2 * spread * (np.cos(phi) if largest else np.cos(phi + 2 * np.pi / 3))
    a, b, c = xx - value, yy - value, zz - value  # the diagonal of A - lambda I
    candidates = np.stack([
        np.stack([xy * yz - xz * b, xz * xy - a * yz, a * b - xy * xy], axis=1),  # row 0 x row 1
        np.stack([xy * c - xz * yz, xz * xz - a * c, a * yz - xy * xz], axis=1),  # row 0 x row 2
        np.stack([b * c - yz * yz, yz * xz - xy * c, xy * yz - b * xz], axis=1),  # row 1 x row 2
    ], axis=1)
    lengths = np.sqrt(np.einsum("nkj,nkj->nk", candidates, candidates))
    best = np.argmax(lengths, axis=1)
    picked = np.arange(len(cov))
    vectors = candidates[picked, best]
    norm = lengths[picked, best]
    result = np.divide(vectors, norm[:, None], out=np.zeros_like(vectors), where=norm[:, None] > 0)
    result[norm <= 0] = (0.0, 0.0, 1.0)
    return result
