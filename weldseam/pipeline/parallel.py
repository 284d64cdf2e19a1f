"""Both cores.

Per-point stages: numpy's array operations, scipy's sparse products and cKDTree release the
GIL on large arrays, so threads run them side by side. Row-wise work is cut into blocks of
rows. Each row's result comes from the same operations in the same order whichever block
holds it, so the output does not depend on the blocks or on the number of cores: it is
byte-identical on every machine.

Cross-sections: each is a few hundred points of small numpy calls, which hold the GIL, so a
forked worker process (sharing the cloud and its search tree copy-on-write) fits half of each
batch (map_shared). Each item's result is computed alone, so again nothing depends on who
computed it.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor
from contextlib import contextmanager

import numpy as np
from scipy import sparse

THREADS = 2
# Below this many rows a thread hand-off (~0.1 ms) costs more than it saves.
MIN_BLOCK_ROWS = 10_000

_pool: ThreadPoolExecutor | None = None
# The forked worker and what it shares with this process (worker_process).
_worker: ProcessPoolExecutor | None = None
_shared: tuple = ()
_worker_busy = False


def _executor() -> ThreadPoolExecutor:
    global _pool
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=THREADS, thread_name_prefix="weldseam")
    return _pool


def _forget_pool() -> None:
    """A forked child has none of its parent's threads or worker: it starts its own."""
    global _pool, _worker
    _pool = _worker = None


os.register_at_fork(after_in_child=_forget_pool)


def in_background(func: Callable, *args, **kwargs) -> Future:
    """Start func(*args, **kwargs) on a worker thread; .result() waits for it (and raises its error)."""
    return _executor().submit(func, *args, **kwargs)


def row_blocks(count: int) -> list[slice]:
    """Up to THREADS contiguous slices covering range(count), none under MIN_BLOCK_ROWS rows."""
    parts = min(THREADS, count // MIN_BLOCK_ROWS)
    if parts > 1:
        parts = min(parts, os.cpu_count() or 1)
    if parts <= 1:
        return [slice(0, count)]
    bounds = np.linspace(0, count, parts + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def run_parts(func: Callable, parts: Sequence) -> list:
    """[func(part) for part in parts], the first part on this thread and the others on the pool."""
    others = [_executor().submit(func, part) for part in parts[1:]]
    return [func(parts[0])] + [other.result() for other in others]


def run_row_blocks(func: Callable[[slice], object], count: int) -> list:
    """[func(block) for block in row_blocks(count)] (run_parts)."""
    return run_parts(func, row_blocks(count))


def map_row_blocks(func: Callable[[slice], np.ndarray], count: int) -> np.ndarray:
    """run_row_blocks, the results concatenated along the first axis (in row order)."""
    results = run_row_blocks(func, count)
    return results[0] if len(results) == 1 else np.concatenate(results)


def graph_rows(graph: sparse.csr_matrix, block: slice) -> sparse.csr_matrix:
    """Rows `block` of a CSR matrix as a CSR matrix sharing its index and data arrays (the
    matrix itself when the block is all of it)."""
    if block.start == 0 and block.stop == graph.shape[0]:
        return graph
    start, stop = graph.indptr[block.start], graph.indptr[block.stop]
    return sparse.csr_matrix(
        (graph.data[start:stop], graph.indices[start:stop], graph.indptr[block.start : block.stop + 1] - start),
        shape=(block.stop - block.start, graph.shape[1]),
    )


@contextmanager
def worker_process(*shared):
    """While open, a forked worker process holds the objects `shared` (large arrays, a search
    tree: never pickled) and map_shared hands it half of each batch. No worker on one core, or
    inside a daemonic process (a multiprocessing pool's worker may not have children)."""
    global _worker, _shared
    if _worker is not None or (os.cpu_count() or 1) < 2 or multiprocessing.current_process().daemon:
        yield
        return
    _shared = shared
    _worker = ProcessPoolExecutor(
        max_workers=1, mp_context=multiprocessing.get_context("fork"), initializer=_leave_interrupts_to_parent
    )
    try:
        yield
    finally:
        worker, _worker, _shared = _worker, None, ()
        worker.shutdown(wait=True, cancel_futures=True)


def _leave_interrupts_to_parent() -> None:
    """Ctrl-C reaches the whole process group: the worker ignores it, and the parent, interrupted,
    closes the worker (after its current batch) and reports the interrupt itself."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def map_shared(func: Callable, shared: tuple, items: Sequence) -> list:
    """[func(*shared, item) for item in items]; while a worker_process holds these very objects
    `shared` and is idle, it computes every second item (func and those items are pickled):
    neighbouring items (sections along one chain) cost alike, so each process gets about half
    of the work even where one stretch of the batch costs more than another. A map_shared inside
    func runs here: the worker is busy with the other items."""
    global _worker_busy
    if _worker is None or _worker_busy or len(items) < 2 or len(shared) != len(_shared) or any(
        a is not b for a, b in zip(shared, _shared)
    ):
        return [func(*shared, item) for item in items]
    theirs = _worker.submit(_map_in_worker, func, list(items[1::2]))
    _worker_busy = True
    try:
        ours = [func(*shared, item) for item in items[::2]]
        return _interleaved(ours, theirs.result())
    finally:
        _worker_busy = False


def _interleaved(evens: list, odds: list) -> list:
    """[evens[0], odds[0], evens[1], odds[1], ...] (len(evens) - len(odds) is 0 or 1)."""
    merged = [None] * (len(evens) + len(odds))
    merged[::2], merged[1::2] = evens, odds
    return merged


def _map_in_worker(func: Callable, items: list) -> list:
    return [func(*_shared, item) for item in items]
