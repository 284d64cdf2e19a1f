import numpy as np

from weldseam.pipeline.boundary import boundary_mask


def test_the_rim_of_a_strip_is_its_two_long_edges_and_its_ends(rng):
    ticks_x, ticks_y = np.arange(0.0, 0.1, 0.001), np.arange(0.0, 0.012, 0.001)
    x, y = (a.ravel() for a in np.meshgrid(ticks_x, ticks_y))
    strip = np.column_stack([x, y, np.zeros(x.size)])
    normals = np.tile([0.0, 0.0, 1.0], (len(strip), 1))
    rim = boundary_mask(strip, normals, radius_m=0.006, shift_ratio=0.25)
    on_edge = (y < 0.0015) | (y > 0.0095) | (x < 0.0015) | (x > 0.0975)
    middle = (np.abs(y - 0.0055) < 0.0011) & (x > 0.01) & (x < 0.09)
    assert rim[on_edge].mean() > 0.95
    assert not rim[middle].any()
