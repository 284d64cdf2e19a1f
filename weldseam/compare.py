"""Compare two sets of weld paths (a result against a golden file): match seams, measure deviations.

Seams are matched by geometry, not by id or order: the assignment (Hungarian) that minimises
the mean distance between matched seams, with direction ignored. For each match:
- position deviation: distance from every pose of one seam to the polyline of the other, both
  ways (max and mean, metres);
- torch-axis deviation: angle between each pose's axis and the axis of the nearest pose of the
  other seam, both ways (max, degrees);
- length difference (metres).
Seams left without a partner, or whose partner is farther than `match_limit_m` on average,
are reported unmatched; they fail any tolerance.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

from weldseam.types import WeldPath

MATCH_LIMIT_M = 0.01


@dataclass(frozen=True)
class SeamComparison:
    """One matched pair (both ids set) or an unmatched seam (the other id None)."""

    seam_a: int | None
    seam_b: int | None
    max_deviation_m: float = float("nan")
    mean_deviation_m: float = float("nan")
    max_axis_deviation_deg: float = float("nan")
    length_difference_m: float = float("nan")

    @property
    def matched(self) -> bool:
        return self.seam_a is not None and self.seam_b is not None

    def within(self, tolerance_m: float, tolerance_deg: float) -> bool:
        return self.matched and self.max_deviation_m <= tolerance_m and self.max_axis_deviation_deg <= tolerance_deg


@dataclass(frozen=True)
class Comparison:
    seams: tuple[SeamComparison, ...]
    count_a: int
    count_b: int

    def within(self, tolerance_m: float, tolerance_deg: float) -> bool:
        return self.count_a == self.count_b and all(seam.within(tolerance_m, tolerance_deg) for seam in self.seams)

    def to_dict(self, tolerance_m: float, tolerance_deg: float) -> dict:
        return {
            "within_tolerance": self.within(tolerance_m, tolerance_deg),
            "tolerance_mm": tolerance_m * 1000,
            "tolerance_deg": tolerance_deg,
            "count_a": self.count_a,
            "count_b": self.count_b,
            "seams": [
                {
                    **{key: value for key, value in asdict(seam).items() if key.startswith("seam_")},
                    "max_deviation_mm": _rounded(seam.max_deviation_m * 1000),
                    "mean_deviation_mm": _rounded(seam.mean_deviation_m * 1000),
                    "max_axis_deviation_deg": _rounded(seam.max_axis_deviation_deg),
                    "length_difference_mm": _rounded(seam.length_difference_m * 1000),
                    "within_tolerance": seam.within(tolerance_m, tolerance_deg),
                }
                for seam in self.seams
            ],
        }


def compare_paths(a: list[WeldPath], b: list[WeldPath], *, match_limit_m: float = MATCH_LIMIT_M) -> Comparison:
    """Match the seams of `a` to those of `b` and measure each pair (see the module doc)."""
    cost = np.array([[_mean_distance(x, y) for y in b] for x in a]).reshape(len(a), len(b))
    rows, cols = linear_sum_assignment(np.minimum(cost, 1e3)) if cost.size else (np.empty(0, int), np.empty(0, int))
    results, used_a, used_b = [], set(), set()
    for i, j in zip(rows, cols):
        if cost[i, j] > match_limit_m:
            continue
        used_a.add(i)
        used_b.add(j)
        results.append(_measured(a[i], b[j]))
    results += [SeamComparison(path.seam_id, None) for k, path in enumerate(a) if k not in used_a]
    results += [SeamComparison(None, path.seam_id) for k, path in enumerate(b) if k not in used_b]
    return Comparison(tuple(results), len(a), len(b))


def _measured(x: WeldPath, y: WeldPath) -> SeamComparison:
    to_y = point_to_polyline(x.positions_m, y.positions_m, y.closed)
    to_x = point_to_polyline(y.positions_m, x.positions_m, x.closed)
    distances = np.concatenate([to_y, to_x])
    return SeamComparison(
        seam_a=x.seam_id,
        seam_b=y.seam_id,
        max_deviation_m=float(distances.max()),
        mean_deviation_m=float(distances.mean()),
        max_axis_deviation_deg=max(_axis_deviation_deg(x, y), _axis_deviation_deg(y, x)),
        length_difference_m=float(x.length_m - y.length_m),
    )


def point_to_polyline(points: np.ndarray, polyline: np.ndarray, closed: bool = False) -> np.ndarray:
    """Distance (K,) from each point (K, 3) to the polyline (S + 1, 3), segment by segment."""
    vertices = np.vstack([polyline, polyline[:1]]) if closed else polyline
    if len(vertices) == 1:
        return np.linalg.norm(points - vertices[0], axis=1)
    starts, spans = vertices[:-1], np.diff(vertices, axis=0)
    lengths2 = np.maximum(np.einsum("ij,ij->i", spans, spans), 1e-24)
    best = np.full(len(points), np.inf)
    for chunk in range(0, len(points), 512):  # bounded memory: 512 x S x 3 at a time
        relative = points[chunk : chunk + 512, None, :] - starts[None]
        t = np.clip(np.einsum("ksj,sj->ks", relative, spans) / lengths2, 0.0, 1.0)
        gaps = relative - t[..., None] * spans[None]
        best[chunk : chunk + 512] = np.sqrt(np.einsum("ksj,ksj->ks", gaps, gaps).min(axis=1))
    return best


def _mean_distance(x: WeldPath, y: WeldPath) -> float:
    return float((point_to_polyline(x.positions_m, y.positions_m, y.closed).mean()
                  + point_to_polyline(y.positions_m, x.positions_m, x.closed).mean()) / 2)


def _axis_deviation_deg(x: WeldPath, y: WeldPath) -> float:
    nearest = cKDTree(y.positions_m).query(x.positions_m)[1]
    cosines = np.einsum("ij,ij->i", x.rotations[:, :, 2], y.rotations[nearest, :, 2])
    return float(np.degrees(np.arccos(np.clip(cosines, -1.0, 1.0))).max())


def _rounded(value: float):
    return None if np.isnan(value) else round(float(value), 6)
