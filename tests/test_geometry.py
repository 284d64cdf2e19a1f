import numpy as np

from weldseam.geometry import column_bounds, even_indices, finite_rows


def test_finite_rows_flags_every_row_with_a_nan_or_infinity_in_any_column(rng):
    points = rng.normal(size=(1000, 3))
    points[[3, 500, 999], [0, 1, 2]] = [np.nan, np.inf, -np.inf]
    finite = finite_rows(points)
    assert np.array_equal(finite, np.isfinite(points).all(axis=1))
    assert np.flatnonzero(~finite).tolist() == [3, 500, 999]


def test_column_bounds_are_each_columns_minimum_and_maximum(rng):
    points = rng.normal(size=(1000, 3)) * [1.0, 10.0, 100.0]
    low, high = column_bounds(points)
    assert np.array_equal(low, points.min(axis=0)) and np.array_equal(high, points.max(axis=0))
    cells = rng.integers(-50, 50, size=(200, 3))
    assert column_bounds(cells)[0].dtype == cells.dtype


def test_even_indices_span_first_to_last_and_take_every_index_when_asked_for_more():
    assert even_indices(10, 4).tolist() == [0, 3, 6, 9]
    assert even_indices(3, 8).tolist() == [0, 1, 2]
    assert even_indices(1, 3).tolist() == [0]
    picks = even_indices(101, 7)
    assert picks[0] == 0 and picks[-1] == 100 and len(picks) == 7 and np.ptp(np.diff(picks)) <= 1
