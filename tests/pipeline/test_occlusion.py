import numpy as np

from weldseam.pipeline.boundary import inward_shift
from weldseam.pipeline.neighbours import centroid_offsets, radius_graph
from weldseam.pipeline.normals import orient_toward, pca_normals
from weldseam.pipeline.occlusion import ViewBuffer, occluded_rims

CAMERA = np.array([0.0, 0.0, 0.5])


def grid(x_range, y_range, z, pitch=0.001):
    x, y = np.meshgrid(np.arange(*x_range, pitch), np.arange(*y_range, pitch))
    return np.column_stack([x.ravel(), y.ravel(), np.full(x.size, z)])


def test_the_view_buffer_finds_what_lies_nearer_on_a_line_of_sight():
    table = grid((-0.05, 0.05), (-0.05, 0.05), 0.0)
    block_top = grid((0.01, 0.03), (-0.02, 0.02), 0.05)
    points = np.vstack([table, block_top])
    view = ViewBuffer.build(points, CAMERA, 0.001)
    behind = np.array([[0.02 * 0.9, 0.0, 0.0]])  # under the block's top, seen through it from the camera
    open_table = np.array([[-0.03, 0.0, 0.0]])
    hit = view.nearer_than(np.vstack([behind, open_table]), margin_m=0.01)
    assert hit[1] == -1
    assert hit[0] >= len(table) and abs(points[hit[0], 2] - 0.05) < 1e-9
    assert view.nearer_than(behind, margin_m=0.06)[0] == -1  # the top is 50 mm nearer, not 60


def test_the_view_buffer_says_where_its_line_of_sight_passes_a_point_and_meets_something_beyond():
    """A table with a hole (x > 0.02) and a block's top 50 mm up: the camera sees past a point
    10 mm over the table, not past one on it, one under the block's top (nearer), or one over
    the hole (nothing seen: a dropout)."""
    table = grid((-0.05, 0.05), (-0.05, 0.05), 0.0)
    table = table[table[:, 0] < 0.02]
    block_top = grid((-0.03, -0.01), (-0.02, 0.02), 0.05)
    view = ViewBuffer.build(np.vstack([table, block_top]), CAMERA, 0.001)
    over, on, under_block, over_hole = [0.0, 0.03, 0.01], [0.0, 0.03, 0.0], [-0.02, 0.0, 0.0], [0.035, 0.0, 0.01]
    assert view.seen_past(np.array([over, on, under_block, over_hole]), 0.004).tolist() == [True, False, False, False]
    assert not view.seen_past(np.array([over]), 0.012)[0], "10 mm beyond it, not 12"


def test_only_the_flanges_end_under_a_wall_is_an_occluded_rim():
    """A flange (z = 0, y > 0) ending at a web's foot (y = 0) whose face the camera (straight above
    the foot) cannot see, the web's top 40 mm up (y in [-8, 0] mm), and a plate edge (x = 0.04)
    with nothing past it."""
    flange = grid((-0.04, 0.04), (0.0, 0.03), 0.0, pitch=0.0025)
    web_top = grid((-0.04, 0.04), (-0.008, 0.0), 0.04, pitch=0.0025)
    points = np.vstack([flange, web_top])
    camera = np.array([0.0, 0.0, 0.45])
    graph = radius_graph(points, 0.006)
    normals = orient_toward(pca_normals(points, graph), points, camera)
    shift = inward_shift(centroid_offsets(graph, points), normals)
    view = ViewBuffer.build(points, camera, 0.001)
    rims = occluded_rims(points, shift, view, min_shift_m=0.25 * 0.006, past_m=(0.003, 0.006, 0.01),
                         margin_m=0.012)
    on_flange = np.arange(len(points)) < len(flange)
    foot = on_flange & (points[:, 1] < 0.001) & (np.abs(points[:, 0]) < 0.03)  # the flange's last row
    assert rims[foot].mean() > 0.9
    assert not rims[on_flange & (points[:, 1] > 0.01)].any()  # not the flange's far edge, nor inside
    assert not rims[~on_flange].any()


def test_the_dense_and_the_sorted_buffer_are_the_same(monkeypatch):
    """Binned densely or sorted (an outlier stretching the bins' box), the buffer holds the same
    nearest point per bin: the least range, the lowest index among equal ranges."""
    rng = np.random.default_rng(3)
    table = grid((-0.05, 0.05), (-0.05, 0.05), 0.0)
    table = table + rng.normal(0.0, 0.0002, table.shape)
    points = np.vstack([table, table[::7] + [0.0, 0.0, 0.02], table[::5]])  # tops, and exact repeats
    dense = ViewBuffer.build(points, CAMERA, 0.001)
    monkeypatch.setattr("weldseam.pipeline.occlusion.MAX_DENSE_BINS_PER_POINT", 0)
    ordered = ViewBuffer.build(points, CAMERA, 0.001)
    assert np.array_equal(dense.keys, ordered.keys) and np.array_equal(dense.nearest, ordered.nearest)
    assert len(dense.keys) > 1000
    repeated = np.arange(0, len(table), 5)
    assert not np.isin(dense.nearest, len(table) + len(table[::7]) + np.arange(len(repeated))).any()
