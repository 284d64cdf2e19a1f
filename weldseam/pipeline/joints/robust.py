"""Small robust statistics on profile points, in closed form: each is called thousands of times
per scan on a few hundred points, where numpy's general routines spend most of their time in
overhead."""

from __future__ import annotations

import numpy as np


def line(u: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """Least-squares line w = intercept + slope * u: (intercept, slope)."""
    count = len(u)
    mean_u, mean_w = float(np.add.reduce(u)) / count, float(np.add.reduce(w)) / count
    du = u - mean_u
    spread = float(du @ du)
    slope = float(du @ (w - mean_w)) / spread if spread > 0 else 0.0
    return float(mean_w - slope * mean_u), slope


def parabola(s: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(c0, c1, c2) of the least-squares parabola n = c0 + c1 s + c2 s^2 (s scaled to [-1, 1]
    for the normal equations)."""
    scale = max(float(np.abs(s).max()), 1e-9)
    x = s / scale
    square = x * x
    solution = least_squares_3((np.ones_like(x), x, square), n)
    return solution / np.array([1.0, scale, scale * scale])


def least_squares_3(columns: tuple[np.ndarray, np.ndarray, np.ndarray], target: np.ndarray) -> np.ndarray:
    """The coefficients k (3,) minimising |k0 a + k1 b + k2 c - target|^2 for `columns` (a, b, c):
    the normal equations G k = r (G_ij = col_i . col_j, r_i = col_i . target) solved by Cramer's
    rule, as np.linalg.lstsq solves them at several times the cost on a few hundred rows; lstsq's
    minimum-norm solution where G is singular (relative determinant under 1e-12)."""
    a, b, c = columns
    gaa, gab, gac, gbb, gbc, gcc = float(a @ a), float(a @ b), float(a @ c), float(b @ b), float(b @ c), float(c @ c)
    ra, rb, rc = float(a @ target), float(b @ target), float(c @ target)
    minor_a, minor_b, minor_c = gbb * gcc - gbc * gbc, gab * gcc - gbc * gac, gab * gbc - gbb * gac
    det = gaa * minor_a - gab * minor_b + gac * minor_c
    if not abs(det) > 1e-12 * gaa * gbb * gcc:
        return np.linalg.lstsq(np.column_stack(columns), target, rcond=None)[0]
    k0 = ra * minor_a - gab * (rb * gcc - gbc * rc) + gac * (rb * gbc - gbb * rc)
    k1 = gaa * (rb * gcc - gbc * rc) - ra * minor_b + gac * (gab * rc - rb * gac)
    k2 = gaa * (gbb * rc - rb * gbc) - gab * (gab * rc - rb * gac) + ra * minor_c
    return np.array([k0, k1, k2]) / det


def parabola_at(coefficients: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The parabola (c0, c1, c2) at s: c0 + c1 s + c2 s^2."""
    return coefficients[0] + coefficients[1] * s + coefficients[2] * s * s


def mean(values: np.ndarray) -> float:
    """The mean, as ndarray.mean gives it, without its overhead."""
    return float(np.add.reduce(values)) / len(values)


def fraction(mask: np.ndarray) -> float:
    """The fraction of a boolean mask that is set (its mean), without the overhead of mean."""
    return np.count_nonzero(mask) / len(mask)


def median(values: np.ndarray) -> float:
    """Upper median, by partition."""
    middle = len(values) // 2
    return float(_partitioned(values, (middle,))[middle])


def middle(values: np.ndarray) -> float:
    """np.median's value, by partition: the middle value, or the mean of the two middle ones (NaN
    if any value is NaN)."""
    if np.isnan(values).any():
        return float("nan")
    half = len(values) // 2
    if len(values) % 2:
        return float(_partitioned(values, (half,))[half])
    ordered = _partitioned(values, (half - 1, half))
    return float((ordered[half - 1] + ordered[half]) / 2)


def quantile(values: np.ndarray, fraction: float) -> float:
    """np.quantile's value (linear interpolation, as numpy rounds it), by partition (NaN if any
    value is NaN)."""
    if np.isnan(values).any():
        return float("nan")
    position = (len(values) - 1) * fraction
    low = int(position)
    if low >= len(values) - 1:
        return float(values.max())
    ordered = _partitioned(values, (low, low + 1))
    below, above, gamma = ordered[low], ordered[low + 1], position - low
    step = above - below
    return float(above - step * (1 - gamma) if gamma >= 0.5 else below + step * gamma)


def _partitioned(values: np.ndarray, kth: tuple[int, ...]) -> np.ndarray:
    """A copy of `values` partitioned at the indices `kth` (each holds its value in sorted order)."""
    ordered = values.copy()
    ordered.partition(kth)
    return ordered


def upper_decile(values: np.ndarray) -> float:
    """The 90th percentile, interpolated as np.percentile does, by partition."""
    position = 0.9 * (len(values) - 1)
    low = int(position)
    high = min(low + 1, len(values) - 1)
    ordered = _partitioned(values, (low, high))
    return float(ordered[low] + (position - low) * (ordered[high] - ordered[low]))


def noise(residuals: np.ndarray) -> float:
    """Robust standard deviation: 1.4826 x the median absolute deviation (+ 10 um floor)."""
    return 1.4826 * median(np.abs(residuals - median(residuals))) + 1e-5


def one_plane(u: np.ndarray, w: np.ndarray, sides: tuple[np.ndarray, np.ndarray], at_u: float, *,
              offset_m: float, angle_rad: float) -> bool:
    """Whether the plate surface left and right of a joint (`sides`: the masks of its points on
    the left and on the right, two or more each) is one plane: lines fitted to each side meet `at_u` within
    `offset_m` of each other, at slopes within `angle_rad`."""
    left, right = sides
    (a_left, b_left), (a_right, b_right) = line(u[left], w[left]), line(u[right], w[right])
    apart = abs((a_left + b_left * at_u) - (a_right + b_right * at_u))
    return apart <= offset_m and abs(np.arctan(b_left) - np.arctan(b_right)) <= angle_rad
