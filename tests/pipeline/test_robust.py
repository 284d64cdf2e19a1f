"""The closed-form statistics the joint models use give numpy's own values, to the bit."""

import numpy as np
import pytest

from weldseam.pipeline.joints.robust import fraction, mean, middle, quantile


@pytest.mark.parametrize("count", [1, 2, 3, 4, 5, 10, 11, 57, 200])
def test_middle_quantile_mean_and_fraction_are_numpys(count):
    rng = np.random.default_rng(count)
    for scale in (1e-4, 1.0, 1e3):
        values = rng.normal(size=count) * scale
        for data in (values, np.round(values, 1)):  # ties too
            assert middle(data) == np.median(data)
            assert mean(data) == data.mean()
            for q in (0.0, 0.25, 0.33, 0.5, 0.8, 0.9, 1.0):
                assert quantile(data, q) == np.quantile(data, q)
            assert fraction(data > 0) == np.mean(data > 0)


def test_a_nan_makes_the_middle_and_the_quantile_nan():
    values = np.array([0.1, np.nan, 0.3])
    assert np.isnan(middle(values)) and np.isnan(quantile(values, 0.8))
