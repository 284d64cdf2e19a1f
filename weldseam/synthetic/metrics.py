"""Score weld paths against a synthetic scene's ground truth (only what the camera saw)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from weldseam.synthetic.scenes import SyntheticScan, SyntheticScene
from weldseam.types import WeldPath


def evaluate(
    paths: Sequence[WeldPath], scan: SyntheticScan, scene: SyntheticScene, *,
    min_seam_length_m: float = 0.020, match_radius_m: float = 0.002, path_step_m: float = 0.0005,
    truth_step_m: float = 0.00005,
) -> dict:
    """Accuracy of `paths` against the truth: coverage of the points `scan.visible` marks as
    observed, position and torch-axis errors against the whole truth (a pose on a stretch of seam
    the mask calls unseen, which the planner measured anyway, lies on the seam: it is no error;
    the mask is a conservative 70-degree view cone).

    Returns a dict of floats/ints:
    seams_found: number of paths.
    seams_expected: truth seams whose visible length >= min_seam_length_m.
    seams_matched: expected seams with coverage >= 0.5.
    mean_position_error_m, max_position_error_m: over all poses of all paths, the distance to
        the nearest truth (truth polylines densified to `truth_step_m`, so sampling adds
        < truth_step_m / 2).
    coverage: fraction of the expected seams' visible length (segments between consecutive
        visible truth points) whose midpoint lies within match_radius_m of a path (poses
        joined by straight segments, densified to path_step_m).
    mean_axis_error_deg: angle between each pose's z column and the torch axis of its
        nearest truth point.
    kinds_matched: expected seams whose path (the one covering most of the seam, at least
        half of it) names the seam's joint kind.
    Values that are undefined (no poses, no truth, or for coverage no visible truth) are NaN.
    """
    segments = [_segments(s, v) for s, v in zip(scene.seams, scan.visible)]
    lengths = [np.linalg.norm(b - a, axis=1).sum() for a, b, _, _ in segments]
    expected = [k for k, length in enumerate(lengths) if length >= min_seam_length_m]

    truth, axes = _densified_truth([_segments(s, np.ones(len(s.points_m), bool)) for s in scene.seams], truth_step_m)
    poses = np.vstack([p.positions_m for p in paths]) if paths else np.empty((0, 3))
    z_axes = np.vstack([p.rotations[:, :, 2] for p in paths]) if paths else np.empty((0, 3))
    position_error, axis_error = np.full(len(poses), np.nan), np.full(len(poses), np.nan)
    if len(truth) and len(poses):
        position_error, nearest = cKDTree(truth).query(poses, workers=-1)
        cosines = np.clip(np.sum(z_axes * axes[nearest], axis=1), -1.0, 1.0)
        axis_error = np.degrees(np.arccos(cosines))

    dense_path = (
        np.vstack([_densify(p.positions_m, p.closed, path_step_m) for p in paths])
        if paths else np.empty((0, 3))
    )
    seam_coverage = [_coverage(*segments[k][:2], dense_path, match_radius_m) for k in expected]
    kinds_matched = sum(
        _covering_joint(segments[k][:2], paths, match_radius_m, path_step_m) == scene.seams[k].joint
        for k in expected
    )
    covered = sum(c * lengths[k] for c, k in zip(seam_coverage, expected))
    total = sum(lengths[k] for k in expected)
    return {
        "seams_found": len(paths),
        "seams_expected": len(expected),
        "seams_matched": sum(c >= 0.5 for c in seam_coverage),
        "mean_position_error_m": _mean(position_error),
        "max_position_error_m": float(position_error.max()) if len(position_error) else np.nan,
        "coverage": covered / total if total > 0 else np.nan,
        "mean_axis_error_deg": _mean(axis_error),
        "kinds_matched": kinds_matched,
    }


def _covering_joint(segment_ends, paths, radius_m: float, step_m: float) -> str | None:
    """The joint kind of the path covering most of a seam's visible segments (start and end
    arrays), if it covers at least half; else None."""
    covered = [_coverage(*segment_ends, _densify(p.positions_m, p.closed, step_m), radius_m) for p in paths]
    best = int(np.argmax(covered)) if covered else -1
    return paths[best].joint if best >= 0 and covered[best] >= 0.5 else None


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if len(values) else np.nan


def _segments(seam, visible: np.ndarray):
    """Segments between consecutive `visible` truth points of one seam: starts, ends (S, 3)
    and the torch axes (S, 3) of their two ends."""
    first = np.arange(len(seam.points_m) if seam.closed else len(seam.points_m) - 1)
    second = (first + 1) % len(seam.points_m)
    keep = visible[first] & visible[second]
    first, second = first[keep], second[keep]
    return (seam.points_m[first], seam.points_m[second],
            seam.torch_axes[first], seam.torch_axes[second])


def _densified_truth(segments, step_m: float):
    """Points every `step_m` along the truth segments (starts, ends, start axes, end axes per
    seam) with the segments' ends (N, 3), and their torch axes (N, 3) (each the axis of the
    nearer original point)."""
    points = [np.empty((0, 3))] + [ends for _, ends, _, _ in segments]
    axes = [np.empty((0, 3))] + [end_axes for _, _, _, end_axes in segments]
    for starts, ends, start_axes, end_axes in segments:
        dense, segment, fraction = _subdivide(starts, ends, step_m)
        points.append(dense)
        axes.append(np.where(fraction[:, None] < 0.5, start_axes[segment], end_axes[segment]))
    return np.vstack(points), np.vstack(axes)


def _subdivide(starts: np.ndarray, ends: np.ndarray, step_m: float):
    """Points at most `step_m` apart on segments starts -> ends (S, 3), ends excluded:
    (P, 3) points, (P,) segment index and (P,) fraction along the segment."""
    counts = np.maximum(1, np.ceil(np.linalg.norm(ends - starts, axis=1) / step_m)).astype(int)
    segment = np.repeat(np.arange(len(starts)), counts)
    first_of_segment = np.repeat(np.cumsum(counts) - counts, counts)
    fraction = (np.arange(counts.sum()) - first_of_segment) / counts[segment]
    return starts[segment] + fraction[:, None] * (ends - starts)[segment], segment, fraction


def _densify(points: np.ndarray, closed: bool, step_m: float) -> np.ndarray:
    """A polyline of poses (K, 3) with points inserted every <= step_m (closing segment
    included when `closed`)."""
    if len(points) < 2:
        return points
    ends = np.roll(points, -1, axis=0) if closed else points[1:]
    dense, _, _ = _subdivide(points[: len(ends)], ends, step_m)
    return dense if closed else np.vstack([dense, points[-1:]])


def _coverage(starts, ends, path_points, radius_m: float) -> float:
    """Length fraction of segments whose midpoint is within `radius_m` of a path point."""
    lengths = np.linalg.norm(ends - starts, axis=1)
    if len(path_points) == 0 or lengths.sum() == 0:
        return 0.0
    distance, _ = cKDTree(path_points).query((starts + ends) / 2, workers=-1)
    return float(lengths[distance <= radius_m].sum() / lengths.sum())
