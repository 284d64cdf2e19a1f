import os
import select

import numpy as np
import pytest

from weldseam.pipeline import parallel
from weldseam.pipeline.descriptor import gradient_descriptor
from weldseam.pipeline.grid import voxel_centroids
from weldseam.pipeline.neighbours import radius_graph
from weldseam.pipeline.normals import pca_normals
from weldseam.pipeline.smooth import smooth_points


@pytest.mark.parametrize("count", [0, 7, parallel.MIN_BLOCK_ROWS, 3 * parallel.MIN_BLOCK_ROWS + 1])
def test_row_blocks_cover_the_rows_in_order(count):
    blocks = parallel.row_blocks(count)
    assert blocks[0].start == 0 and blocks[-1].stop == count
    assert all(a.stop == b.start for a, b in zip(blocks, blocks[1:]))
    assert len(blocks) <= parallel.THREADS
    assert len(blocks) == 1 or min(b.stop - b.start for b in blocks) >= parallel.MIN_BLOCK_ROWS


def _per_point_stages(points):
    graph = radius_graph(points, 0.006)
    smoothed = smooth_points(points, graph, radius_m=0.006)
    normals = pca_normals(smoothed, graph)
    return smoothed, normals, gradient_descriptor(normals, graph)


def test_per_point_stages_are_byte_identical_in_one_or_several_blocks(monkeypatch, rng):
    # A noisy folded sheet: creases, noise and uneven neighbourhoods.
    u, v = rng.uniform(-0.05, 0.05, (2, 4000))
    points = np.column_stack([u, v, 0.3 * np.abs(u) + rng.normal(0, 0.0005, len(u))])
    monkeypatch.setattr(parallel, "MIN_BLOCK_ROWS", 1)
    monkeypatch.setattr(parallel, "THREADS", 1)
    single = _per_point_stages(points)
    monkeypatch.setattr(parallel, "THREADS", 2)
    monkeypatch.setattr(parallel.os, "cpu_count", lambda: 2)
    assert len(parallel.row_blocks(len(points))) == 2
    for one, two in zip(single, _per_point_stages(points)):
        assert one.tobytes() == two.tobytes()


def test_the_voxel_grid_is_byte_identical_in_one_or_several_key_ranges(monkeypatch, rng):
    points = rng.normal(0, 0.02, (20000, 3))
    monkeypatch.setattr(parallel, "MIN_BLOCK_ROWS", 1)
    monkeypatch.setattr(parallel, "THREADS", 1)
    single = voxel_centroids(points, 0.001)
    monkeypatch.setattr(parallel, "THREADS", 2)
    monkeypatch.setattr(parallel.os, "cpu_count", lambda: 2)
    split = voxel_centroids(points, 0.001)
    assert single.tobytes() == split.tobytes()
    cells = np.unique(np.floor((points - points.min(axis=0)) / 0.001), axis=0)
    assert len(single) == len(cells)


def test_a_background_error_is_raised_where_the_result_is_taken():
    with pytest.raises(ZeroDivisionError):
        parallel.in_background(lambda: 1 / 0).result()


def test_a_forked_child_runs_blocks_on_a_pool_of_its_own(monkeypatch):
    """Worker processes are forked (the accuracy benchmark, batch runs) after the parent's pool
    has threads; the child must not wait on threads it does not have."""
    monkeypatch.setattr(parallel, "MIN_BLOCK_ROWS", 1)
    monkeypatch.setattr(parallel.os, "cpu_count", lambda: 2)
    parallel.in_background(int).result()  # the parent's pool is running
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:
        total = parallel.map_row_blocks(lambda rows: np.arange(rows.start, rows.stop), 10).sum()
        os.write(write_end, str(total).encode())
        os._exit(0)
    os.close(write_end)
    ready, _, _ = select.select([read_end], [], [], 30)
    if not ready:
        os.kill(pid, 9)
    os.waitpid(pid, 0)
    assert ready and os.read(read_end, 100) == b"45"


def _item_and_process(shared: list, item: int) -> tuple[int, int, int]:
    return item, shared[item], os.getpid()


def test_the_worker_process_maps_every_second_item_and_the_results_keep_their_order(monkeypatch):
    """map_shared: the results come in the items' order whoever computed them, the worker computing
    the odd items (neighbouring sections cost alike: each process gets half of every stretch)."""
    monkeypatch.setattr(parallel.os, "cpu_count", lambda: 2)
    shared = [10 * k for k in range(7)]
    with parallel.worker_process(shared):
        results = parallel.map_shared(_item_and_process, (shared,), list(range(7)))
    assert [(item, value) for item, value, _ in results] == [(k, 10 * k) for k in range(7)]
    processes = [pid for _, _, pid in results]
    assert set(processes[::2]) == {os.getpid()} and os.getpid() not in processes[1::2]
