import numpy as np

from weldseam.report.figure import RAMP, colours, decimate, make_drawing, torch_arrows


def test_decimation_keeps_the_budget_spread_over_the_cloud_and_drops_nan():
    points = np.arange(3000.0).reshape(-1, 3)
    points[5] = np.nan
    kept = decimate(points, 100)
    assert len(kept) == 100 and 5 not in kept
    assert kept[0] == 0 and kept[-1] == 999 and np.all(np.diff(kept) > 0)
    assert np.array_equal(decimate(points, 100), kept)  # deterministic
    assert len(decimate(points, 5000)) == 999


def test_colours_run_along_the_ramp():
    rgb = colours(np.linspace(0, 1, 101))
    assert np.array_equal(rgb[0], RAMP[0]) and np.array_equal(rgb[-1], RAMP[-1])


def test_torch_arrows_end_on_the_seam_and_come_from_above(plate_and_path):
    _, (path,), _ = plate_and_path
    tails, heads = torch_arrows(path, count=20, length_m=0.015)
    assert len(heads) == 20
    assert np.array_equal(heads[[0, -1]], path.positions_m[[0, -1]])
    assert np.all(np.isin(heads[:, 0], path.positions_m[:, 0]))
    assert np.allclose(tails - heads, [0.0, 0.0, 0.015])  # torch axis is -z: the arrow comes down onto the seam


def test_the_drawing_honours_the_point_budget(plate_and_path):
    points, paths, _ = plate_and_path
    drawing = make_drawing(points, paths, point_budget=1000)
    assert len(drawing.scan_m) == 1000 and np.allclose(drawing.scan_values, drawing.scan_m[:, 2])
    assert np.array_equal(drawing.seams[0].positions_m, paths[0].positions_m)
