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


def median(values: np.ndarray) -> float:
    """Upper median, by partition."""
    middle = len(values) // 2
    ordered = values.copy()
    ordered.partition(middle)
    return float(ordered[middle])


def upper_decile(values: np.ndarray) -> float:
    """The 90th percentile, interpolated as np.percentile does, by partition."""
    position = 0.9 * (len(values) - 1)
    low = int(position)
    high = min(low + 1, len(values) - 1)
    ordered = values.copy()
    ordered.partition((low, high))
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
