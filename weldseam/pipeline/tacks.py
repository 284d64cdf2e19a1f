"""Tacks: the tack welds on each seam, where material stands over the seam line.

A tack is part of its seam: the path runs across it on the seam line, never over its top. The
trace steps over the few sections it spoils, an extension crosses it (across_tack), and each
path records its tacks with where they sit and how long they are (tacks_of).

At a seam point c with torch axis a (into the work) and travel t, material stands over the seam
where points of the scan lie within LATERAL_M of the line c - h a (across the seam: l = t x a),
within half a pose spacing along the seam, at a height h = -(p - c) . a of MIN_HEIGHT_M to
MAX_HEIGHT_M. Over a groove's opening or a square butt's gap there is nothing there, and at an
inside corner the faces rise no higher than LATERAL_M / tan(half the included angle) (0.9 mm at
60 degrees); a tack's dome stands 1.5-3 mm over the seam; a clamp over it stands higher.
"""

from __future__ import annotations

import numpy as np

from weldseam.geometry import arc_lengths, unit
from weldseam.pipeline.ends import ahead, offsets
from weldseam.pipeline.section import SectionFit
from weldseam.pipeline.seek import Extension, next_fit, plain_fit
from weldseam.types import Tack

MIN_HEIGHT_M = 0.001
MAX_HEIGHT_M = 0.008
LATERAL_M = 0.0005
# A tack is a run of poses with points over them, at least MIN_LENGTH_M long, with CORE_POINTS
# or more over CORE_POSES poses in a row: a dome's low ends hold a point or none. Where more than
# STRAY_SHARE of a seam's poses have a point over them anyway (at an inside corner, the faces'
# noise and stray points), a pose needs two to count.
MIN_LENGTH_M = 0.003
CORE_POINTS = 2
CORE_POSES = 2
STRAY_SHARE = 0.1
# An extension crosses a tack up to this long (tacks are 6-12 mm, the sections spoiled at
# either end of one add a few mm), when the seam fits again beyond it this many times in a row.
MAX_TACK_M = 0.025
TACK_CONFIRM = 2


def points_over(positions_m: np.ndarray, axes: np.ndarray, points: np.ndarray, tree) -> np.ndarray:
    """(K,) how many of `points` (N, 3; `tree` searches them) stand over each seam point
    (positions (K, 3) in travel order, torch axes (K, 3) into the work): see the module."""
    count = len(positions_m)
    if count < 2:
        return np.zeros(count, int)
    travel = np.gradient(positions_m, axis=0)
    spacing = np.linalg.norm(travel, axis=1)
    travel /= np.maximum(spacing, 1e-12)[:, None]
    lateral = np.cross(travel, axes)
    middle = (MIN_HEIGHT_M + MAX_HEIGHT_M) / 2
    reach = np.hypot(MAX_HEIGHT_M - middle, np.hypot(LATERAL_M, spacing.max()))
    near = tree.query_ball_point(positions_m - middle * axes, reach, workers=-1)
    counts = np.zeros(count, int)
    for k, members in enumerate(near):
        if not members:
            continue
        offsets_m = points[members] - positions_m[k]
        height = -(offsets_m @ axes[k])
        over = ((height >= MIN_HEIGHT_M) & (height <= MAX_HEIGHT_M) & (np.abs(offsets_m @ lateral[k]) <= LATERAL_M)
                & (np.abs(offsets_m @ travel[k]) <= spacing[k] / 2))  # fmt: skip
        counts[k] = np.count_nonzero(over)
    return counts


def tacks_of(positions_m: np.ndarray, over_counts: np.ndarray) -> tuple[Tack, ...]:
    """The tacks along a seam (positions (K, 3) in travel order) from the points over each of its
    poses (points_over): see MIN_LENGTH_M. Each is as long as its run's arc plus one pose
    spacing; its middle is the seam point halfway along the run."""
    strong = over_counts >= CORE_POINTS
    stray = np.mean((over_counts > 0) & ~strong) > STRAY_SHARE
    covered = strong if stray else over_counts > 0
    edges = np.diff(np.concatenate(([0], covered.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    arc = arc_lengths(positions_m)
    spacing = arc[-1] / max(len(arc) - 1, 1)
    tacks = []
    for start, end in zip(starts, ends):
        length = arc[end - 1] - arc[start] + spacing
        if length < MIN_LENGTH_M or not _in_a_row(strong[start:end], CORE_POSES):
            continue
        halfway = (arc[start] + arc[end - 1]) / 2
        middle = [np.interp(halfway, arc, positions_m[:, k]) for k in range(3)]
        tacks.append(Tack(tuple(round(float(v), 6) for v in middle), round(float(length), 6)))
    return tuple(tacks)


def across_tack(extension: Extension, last_point, last_axis, direction, bend) -> list[SectionFit] | None:
    """Bridged points across a tack just ahead of a seam's end, then the first TACK_CONFIRM fits
    beyond it; None where no tack stands there.

    A tack stands ahead when CORE_POINTS stand over CORE_POSES of the points predicted along the
    end's curve (ends.ahead) within a few steps. The seam then fits again within MAX_TACK_M ahead
    (the first section of the extension's joint whose seam point lies within the tolerances of
    seek.next_fit of its prediction, with nothing over it), TACK_CONFIRM times in a row; the tack
    is bridged on the straight line between the end and that fit (its sections see the tack, not
    the seam: the seam runs on under it), torch axes interpolated."""
    step = extension.params.step_m
    surface = extension.surface
    distances = np.arange(step, MAX_TACK_M + step / 2, step)
    predicted = np.array([ahead(last_point, direction, bend, d)[0] for d in distances])
    axes = np.repeat(last_axis[None], len(distances), axis=0)
    over = points_over(np.vstack([last_point, predicted]), np.vstack([last_axis, axes]), surface.points, surface.tree)[1:]
    if not _in_a_row(over[:4] >= CORE_POINTS, CORE_POSES):
        return None
    for distance, centre, count in zip(distances, predicted, over):
        if count or distance <= 2 * step:
            continue
        travel = ahead(last_point, direction, bend, distance)[1]
        fit = plain_fit(extension, centre, travel, last_axis)
        depth, sideways = offsets(fit.point_m, centre, travel, last_axis)
        near = sideways <= max(1.5 * step, 0.15 * distance) and depth <= max(0.5 * step, 0.2 * distance)
        if fit.kind != extension.joint or not near:
            continue
        run = [fit]
        while len(run) < TACK_CONFIRM:
            following = next_fit(extension, run[-1].point_m, run[-1].torch_axis, (travel, bend))
            if following is None:
                return None
            run.append(following)
        return _bridge(extension, last_point, last_axis, fit) + run
    return None


def _bridge(extension: Extension, last_point, last_axis, fit: SectionFit) -> list[SectionFit]:
    """Bridged SectionFits about a step apart strictly between `last_point` and `fit` on the
    straight line, torch axes interpolated."""
    count = max(1, int(round(np.linalg.norm(fit.point_m - last_point) / extension.params.step_m)))
    weights = (np.arange(1, count) / count)[:, None]
    points = (1 - weights) * last_point + weights * fit.point_m
    tilts = unit((1 - weights) * last_axis + weights * fit.torch_axis)
    return [SectionFit(extension.joint, p, a, fit.geometry, bridged=True) for p, a in zip(points, tilts)]


def _in_a_row(flags: np.ndarray, count: int) -> bool:
    """Whether `count` consecutive entries of `flags` are all True."""
    return len(flags) >= count and bool(np.any(np.convolve(flags.astype(int), np.ones(count, int), "valid") == count))
