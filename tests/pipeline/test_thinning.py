import numpy as np

from weldseam.pipeline import thinning
from weldseam.pipeline.thinning import thin_points


def band(rng, count=800, centre_y=0.0):
    x = rng.uniform(0.0, 0.1, count)
    return np.column_stack([x, centre_y + rng.uniform(-0.002, 0.002, count), rng.uniform(-0.001, 0.001, count)])


def test_a_scattered_band_contracts_onto_its_centre_line(rng):
    (thinned,) = thin_points([band(rng)], radius_m=0.005, iterations=20)
    # Away from the ends, whose neighbourhoods are one-sided.
    inner = thinned[(thinned[:, 0] > 0.01) & (thinned[:, 0] < 0.09)]
    assert len(inner) > 500
    assert np.abs(inner[:, 1:]).max() < 0.0003 and np.ptp(inner[:, 0]) > 0.075  # across only, not along


def test_sets_thinned_together_are_each_thinned_as_alone(rng):
    # Two bands 4 mm apart, closer than the radius: as one set they would merge into one line.
    near, far = band(rng, centre_y=0.0), band(rng, centre_y=0.004)
    together = thin_points([near, far, np.zeros((0, 3))], radius_m=0.005, iterations=20)
    alone = [thin_points([points], radius_m=0.005, iterations=20)[0] for points in (near, far)]
    assert len(together) == 3 and len(together[2]) == 0
    for joint, single, centre_y in zip(together, alone, (0.0, 0.004)):
        assert joint.shape == single.shape and np.allclose(joint, single, rtol=0, atol=1e-12)
        inner = joint[(joint[:, 0] > 0.01) & (joint[:, 0] < 0.09)]
        assert np.abs(inner[:, 1] - centre_y).max() < 0.0003


def test_thinning_stops_once_the_points_have_settled(rng, monkeypatch):
    searched = []
    counting = thinning.radius_pairs

    def counted(points, radius_m):
        searched.append(len(points))
        return counting(points, radius_m)

    monkeypatch.setattr(thinning, "radius_pairs", counted)
    line = np.column_stack([np.arange(0.0, 0.05, 0.001), np.zeros(50), np.zeros(50)])
    scattered = band(rng, count=300, centre_y=0.05)
    thinned_line, thinned_band = thin_points([line, scattered], radius_m=0.005, iterations=20)
    assert np.abs(thinned_line - line).max() < 1e-9 and np.abs(thinned_band - scattered).max() > 1e-4
    # The neighbour count and one iteration that moves nothing search the line; the band goes on.
    assert searched.count(len(line)) == 2 and len(searched) > 4


def test_each_set_is_thinned_over_its_own_radius(rng):
    """A band 20 mm wide (a wide valley's, found over a 20 mm radius) gathers on its centre line
    when thinned over half its width, not over the 5 mm a descriptor band is thinned over."""
    along, across = np.meshgrid(np.arange(0.0, 0.06, 0.0025), np.arange(-0.01, 0.01001, 0.0025))
    band = np.column_stack([along.ravel(), across.ravel(), np.zeros(along.size)]) + rng.normal(0, 0.0003, (along.size, 3))
    fine, wide = thin_points([band, band], radius_m=[0.005, 0.01], iterations=20)
    inner = (band[:, 0] > 0.01) & (band[:, 0] < 0.05)  # every point is kept: thinned point k is band point k
    assert np.abs(wide[inner, 1]).max() < 0.0005
    assert np.abs(fine[inner, 1]).max() > 0.001
