import numpy as np

from weldseam.pipeline import thinning
from weldseam.pipeline.thinning import thin_points


def test_a_scattered_band_contracts_onto_its_centre_line(rng):
    x = rng.uniform(0.0, 0.1, 800)
    band = np.column_stack([x, rng.uniform(-0.002, 0.002, 800), rng.uniform(-0.001, 0.001, 800)])
    thinned = thin_points(band, radius_m=0.005, iterations=20)
    # Away from the ends, whose neighbourhoods are one-sided.
    inner = thinned[(thinned[:, 0] > 0.01) & (thinned[:, 0] < 0.09)]
    assert len(inner) > 500
    assert np.abs(inner[:, 1:]).max() < 0.0003 and np.ptp(inner[:, 0]) > 0.075  # across only, not along


def test_thinning_stops_once_the_points_have_settled(monkeypatch):
    graphs = []
    counting = thinning.radius_graph

    def counted(points, radius_m):
        graphs.append(len(points))
        return counting(points, radius_m)

    monkeypatch.setattr(thinning, "radius_graph", counted)
    line = np.column_stack([np.arange(0.0, 0.05, 0.001), np.zeros(50), np.zeros(50)])
    thinned = thin_points(line, radius_m=0.005, iterations=20)
    assert np.abs(thinned - line).max() < 1e-9
    assert len(graphs) == 2  # the neighbour count, then one iteration that moves nothing
