"""The closed-form statistics the joint models use give numpy's own values, to the bit; their
least squares give lstsq's solution to rounding."""

import numpy as np
import pytest

from weldseam.pipeline.joints.robust import fraction, least_squares_3, mean, middle, parabola, quantile


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


@pytest.mark.parametrize("count", [3, 5, 40, 300])
def test_three_column_least_squares_is_lstsqs_solution(count):
    rng = np.random.default_rng(count)
    u = np.sort(rng.uniform(-0.02, 0.03, count))
    w = 0.004 - 0.3 * u + 12.0 * u * u + rng.normal(0, 2e-4, count)
    expected = np.linalg.lstsq(np.column_stack([np.ones(count), u, u * u]), w, rcond=None)[0]
    np.testing.assert_allclose(parabola(u, w), expected, rtol=1e-9, atol=1e-12)
    columns = (u, np.sin(40 * u), np.ones(count))
    expected = np.linalg.lstsq(np.column_stack(columns), w, rcond=None)[0]
    np.testing.assert_allclose(least_squares_3(columns, w), expected, rtol=1e-9, atol=1e-12)


def test_dependent_columns_give_lstsqs_minimum_norm_solution():
    u = np.linspace(0.0, 1.0, 20)
    columns = (u, 0.3 * u + 2.0, np.ones(20))  # the second is a sum of the others
    target = np.cos(3 * u)
    expected = np.linalg.lstsq(np.column_stack(columns), target, rcond=None)[0]
    np.testing.assert_allclose(least_squares_3(columns, target), expected, rtol=1e-9)
    same_u = np.full(8, 0.01)  # one u: a line, not a parabola
    fitted = parabola(same_u, np.full(8, 0.002))
    assert np.all(np.isfinite(fitted)) and abs(fitted[0] + fitted[1] * 0.01 + fitted[2] * 1e-4 - 0.002) < 1e-12
