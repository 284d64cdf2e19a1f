"""Both cores for the per-point stages: numpy's array operations, scipy's sparse products and
cKDTree release the GIL on large arrays, so threads run them side by side.

Row-wise work is cut into blocks of rows. Each row's result comes from the same operations in
the same order whichever block holds it, so the output does not depend on the blocks or on
the number of cores: it is byte-identical on every machine.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np
from scipy import sparse

THREADS = 2
# Below this many rows a thread hand-off (~0.1 ms) costs more than it saves.
MIN_BLOCK_ROWS = 10_000

_pool: ThreadPoolExecutor | None = None


def _executor() -> ThreadPoolExecutor:
    global _pool
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=THREADS, thread_name_prefix="weldseam")
    return _pool


def _forget_pool() -> None:
    """A forked child has none of its parent's threads: it starts a pool of its own."""
    global _pool
    _pool = None


os.register_at_fork(after_in_child=_forget_pool)


def in_background(func: Callable, *args, **kwargs) -> Future:
    """Start func(*args, **kwargs) on a worker thread; .result() waits for it (and raises its error)."""
    return _executor().submit(func, *args, **kwargs)


def row_blocks(count: int) -> list[slice]:
    """Up to THREADS contiguous slices covering range(count), none under MIN_BLOCK_ROWS rows."""
    parts = max(1, min(THREADS, count // MIN_BLOCK_ROWS, os.cpu_count() or 1))
    bounds = np.linspace(0, count, parts + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def run_row_blocks(func: Callable[[slice], object], count: int) -> list:
    """[func(block) for block in row_blocks(count)], the first block on this thread and the
    others on the pool."""
    blocks = row_blocks(count)
    others = [_executor().submit(func, block) for block in blocks[1:]]
    return [func(blocks[0])] + [other.result() for other in others]


def map_row_blocks(func: Callable[[slice], np.ndarray], count: int) -> np.ndarray:
    """run_row_blocks, the results concatenated along the first axis (in row order)."""
    results = run_row_blocks(func, count)
    return results[0] if len(results) == 1 else np.concatenate(results)


def graph_rows(graph: sparse.csr_matrix, block: slice) -> sparse.csr_matrix:
    """Rows `block` of a CSR matrix as a CSR matrix sharing its index and data arrays."""
    start, stop = graph.indptr[block.start], graph.indptr[block.stop]
    return sparse.csr_matrix(
        (graph.data[start:stop], graph.indices[start:stop], graph.indptr[block.start : block.stop + 1] - start),
        shape=(block.stop - block.start, graph.shape[1]),
    )
