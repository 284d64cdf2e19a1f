"""What a report shows, as plain arrays: decimated scan, colours, path lines, torch arrows, marks.

Both renderers (`html.py` with plotly, `png.py` with Pillow) draw this same data, so the
static picture and the interactive page agree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from weldseam.geometry import even_indices
from weldseam.types import WeldPath

DEFAULT_POINT_BUDGET = 60_000
ARROWS_PER_SEAM = 25
ARROW_LENGTH_M = 0.015
# A perceptually ordered ramp (viridis, 5 stops) for heights or descriptor values.
RAMP = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], dtype=float)
# Pose confidence 0, 0.5, 1: white, amber, the path's red. Luminance falls as confidence rises, and
# none of the three is on RAMP, so an unsure stretch stands out on the scan whatever colours it.
CONFIDENCE_RAMP = np.array([[255, 255, 255], [255, 170, 0], [230, 25, 75]], dtype=float)


@dataclass(frozen=True)
class SeamDrawing:
    """One seam: its poses (K, 3), arrow tails (A, 3) and heads (A, 3), its label and its poses'
    confidence (K,) 0..1 (all 1 for a path that has none, such as one read from CSV)."""

    seam_id: int
    positions_m: np.ndarray
    arrow_tails_m: np.ndarray
    arrow_heads_m: np.ndarray
    label: str
    pose_confidence: np.ndarray


@dataclass(frozen=True)
class Drawing:
    scan_m: np.ndarray
    scan_values: np.ndarray
    value_name: str
    candidates_m: np.ndarray
    seams: tuple[SeamDrawing, ...]


def decimate(points: np.ndarray, budget: int) -> np.ndarray:
    """Indices of at most `budget` points, spread evenly over the cloud's order, deterministic."""
    finite = np.flatnonzero(np.isfinite(points).all(axis=1))
    if len(finite) <= budget:
        return finite
    return finite[np.linspace(0, len(finite) - 1, budget).round().astype(int)]


def colours(values: np.ndarray) -> np.ndarray:
    """RGB (N, 3) uint8 from `values` through RAMP, stretched between the 2nd and 98th percentile."""
    if len(values) == 0:
        return np.zeros((0, 3), np.uint8)
    low, high = np.percentile(values, [2, 98])
    return _through(RAMP, np.clip((values - low) / max(high - low, 1e-12), 0, 1))


def confidence_colours(confidence: np.ndarray) -> np.ndarray:
    """RGB (K, 3) uint8 of pose confidences 0..1 through CONFIDENCE_RAMP (0 white, 1 the path's red)."""
    return _through(CONFIDENCE_RAMP, np.clip(np.asarray(confidence, dtype=np.float64), 0, 1))


def _through(ramp: np.ndarray, fraction: np.ndarray) -> np.ndarray:
    """RGB (N, 3) uint8 at `fraction` (N,) 0..1 along `ramp`, linear between its evenly spaced stops."""
    t = fraction * (len(ramp) - 1)
    below = np.minimum(t.astype(int), len(ramp) - 2)
    part = (t - below)[:, None]
    return ((1 - part) * ramp[below] + part * ramp[below + 1]).round().astype(np.uint8)


def torch_arrows(path: WeldPath, count: int = ARROWS_PER_SEAM, length_m: float = ARROW_LENGTH_M):
    """Tails and heads (A, 3) of arrows along the torch axis at `count` evenly spaced poses
    (both ends included; every pose when fewer): each arrow ends at the seam point and comes
    from `length_m` back along the axis."""
    chosen = even_indices(len(path.positions_m), count)
    heads = path.positions_m[chosen]
    return heads - length_m * path.rotations[chosen, :, 2], heads


def make_drawing(
    points_m: np.ndarray,
    paths: list[WeldPath],
    *,
    values: np.ndarray | None = None,
    value_name: str = "height (m)",
    candidates_m: np.ndarray | None = None,
    point_budget: int = DEFAULT_POINT_BUDGET,
) -> Drawing:
    """The report's content; `values` (per point of `points_m`) colour the scan, else its z."""
    keep = decimate(points_m, point_budget)
    scan = points_m[keep]
    shown = scan[:, 2] if values is None else np.asarray(values, dtype=np.float64)[keep]
    candidates = np.empty((0, 3)) if candidates_m is None else candidates_m[decimate(candidates_m, point_budget // 4)]
    seams = []
    for path in paths:
        tails, heads = torch_arrows(path)
        kind = f"{path.joint or 'unknown joint'}{', closed' if path.closed else ''}"
        confidence = np.ones(len(path.positions_m)) if path.pose_confidence is None else path.pose_confidence
        label = f"seam {path.seam_id} ({kind})"
        seams.append(SeamDrawing(path.seam_id, path.positions_m, tails, heads, label, np.asarray(confidence, float)))
    return Drawing(scan, shown, value_name if values is not None else "height (m)", candidates, tuple(seams))


def pose_summary(seam: dict) -> tuple[float, int]:
    """(lowest pose confidence, how many poses are below 1) of a seam of the path JSON; a pose
    without a confidence counts as 1, a seam without poses gives (1.0, 0)."""
    confidence = [pose.get("confidence", 1.0) for pose in seam.get("poses", [])]
    return min(confidence, default=1.0), sum(c < 1 for c in confidence)
