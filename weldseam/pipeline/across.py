"""Across: two pieces of one seam either side of a hole in the scan joined across it.

An end is carried across a hole only as far as extend.max_hole_m, predicted from its own side
(holes.across_hole); its heading, read where the hole's edge cuts its sections short, may be off
by several degrees, and the prediction strays by that angle times the distance. Where the seam
was traced on both sides, the two pieces bound the stretch between from both ends: each end
carries the seam max_hole_m toward the other, so pieces up to twice that apart are joined when
they lie in line (each one's line passes the other's facing end within a quarter of the gap
sideways, as an extension's fit beyond a hole must) and the gap is a hole: the camera saw
nothing along its line of sight through the curve between them, neither on it nor beyond it,
between the hole's ragged edges (the failed sections an extension steps over anyway).
Past a part's end it sees what lies beyond (the table, the gap between two parts), and over a
groove it sees the groove's bottom: those are no hole. The stretch between is interpolated
(PointFlag.INTERPOLATED) and recorded as a hole.
"""

from __future__ import annotations

import numpy as np

from weldseam.config import ExtendConfig
from weldseam.geometry import arc_lengths, unit
from weldseam.pipeline.ends import TANGENT_BASELINE_M, seam_line
from weldseam.pipeline.holes import HOLE_RADIUS_M, empty_between_edges, hermite, hidden, hole_of
from weldseam.pipeline.joints import one_joint
from weldseam.pipeline.section import FineSurface, PointFlag, SectionFit
from weldseam.pipeline.trace import TracedSeam, end_to_end

# Each end carries the seam max_hole_m toward the other.
ENDS = 2
# A piece in line with another: the other's facing end within this share of the gap of its line.
SIDEWAYS_SHARE = 0.25
# How far past each point of the curve the camera's line of sight is searched for a surface
# seen through the gap (a table under a part lies well within it), and from how far before it.
SIGHT_REACH_M = 0.1
SIGHT_BEFORE_M = 0.002


def join_across_holes(
    seams: list[TracedSeam], surface: FineSurface, camera_m: np.ndarray, params: ExtendConfig, join_m: float
) -> list[TracedSeam]:
    """The seams with pieces of one seam either side of a hole joined across it (see the module),
    the closest pair first, until none is left; pieces within join_m are join's. `camera_m`: the
    one camera's origin (3,); with several (one per point) no line of sight is known and nothing
    is joined."""
    if np.ndim(camera_m) != 1:
        return seams
    pieces = list(seams)
    while True:
        found = [(gap, i, j, merged) for i in range(len(pieces)) for j in range(i + 1, len(pieces))
                 for gap, merged in [_across(pieces[i], pieces[j], surface, camera_m, params, join_m)]
                 if merged is not None]  # fmt: skip
        if not found:
            return pieces
        _, i, j, merged = min(found, key=lambda item: item[:3])
        pieces[i] = merged
        pieces.pop(j)


def _across(first: TracedSeam, second: TracedSeam, surface, camera_m, params: ExtendConfig, join_m: float):
    """(gap, joined seam) for the closest way to join `first` and `second` across a hole, or
    (inf, None)."""
    best = (np.inf, None)
    if first.closed or second.closed or not one_joint(first.joint, second.joint):
        return best
    if min(first.length_m, second.length_m) < TANGENT_BASELINE_M:
        return best
    for a in (first, first.reversed()):
        for b in (second, second.reversed()):
            gap = float(np.linalg.norm(b.positions_m[0] - a.positions_m[-1]))
            if not join_m < gap <= ENDS * params.max_hole_m or gap >= best[0]:
                continue
            bridge = _bridge(a, b, surface, camera_m, params.step_m, params.max_skip_m)
            if bridge is not None:
                hole = hole_of(a.positions_m[-1], [*bridge, SectionFit(b.joint, b.positions_m[0], b.torch_axes[0])])
                between = ([f.point_m for f in bridge], [f.torch_axis for f in bridge], [f.flags for f in bridge])
                best = (gap, end_to_end(a, between, b, (hole,)))
    return best


def _bridge(
    a: TracedSeam, b: TracedSeam, surface, camera_m, step_m: float, max_edge_m: float
) -> list[SectionFit] | None:
    """The interpolated points from a's end to b's start on the cubic Hermite curve along their
    lines (ends.seam_line), or None unless each piece's line passes the other's facing end within
    SIDEWAYS_SHARE of the gap, the camera saw no surface through the curve (seen_through) between
    the hole's edges, each at most `max_edge_m` long (holes.empty_between_edges: at a hole's ragged
    edge it sees the groove or the part's surfaces beside the seam, where the sections failed), and
    nothing in front of it hides the curve (holes.hidden)."""
    leaving = seam_line(a.positions_m)
    arriving = seam_line(b.positions_m[::-1])
    if leaving is None or arriving is None:
        return None
    start, end = a.positions_m[-1], b.positions_m[0]
    gap = end - start
    distance = float(np.linalg.norm(gap))
    for line, point in ((leaving, end), (arriving, start)):
        offset = point - line.point
        if np.linalg.norm(offset - (offset @ line.direction) * line.direction) > SIDEWAYS_SHARE * distance:
            return None
    if gap @ leaving.direction <= 0 or gap @ arriving.direction >= 0:
        return None  # the pieces do not face each other
    curve = hermite(start, leaving.direction, end, -arriving.direction, min(step_m, HOLE_RADIUS_M))
    arc = arc_lengths(np.vstack([start, curve, end]))[1:]  # from `start`, on to `end`
    if not empty_between_edges(seen_through(curve, surface, camera_m), arc, max_edge_m) or hidden(curve, surface):
        return None
    points = hermite(start, leaving.direction, end, -arriving.direction, step_m)
    weights = np.linspace(0.0, 1.0, len(points) + 2)[1:-1, None]
    axes = unit((1 - weights) * a.torch_axes[-1] + weights * b.torch_axes[0])
    return [SectionFit(a.joint, p, axis, bridged=True, flags=int(PointFlag.INTERPOLATED))
            for p, axis in zip(points, axes)]  # fmt: skip


def seen_through(curve: np.ndarray, surface: FineSurface, camera_m: np.ndarray) -> np.ndarray:
    """(K,) how many scan points lie within HOLE_RADIUS_M of the camera's line of sight through
    each of the `curve`'s points (K, 3), from SIGHT_BEFORE_M before it to SIGHT_REACH_M past it,
    sampled every HOLE_RADIUS_M (a point near two samples counts twice)."""
    sight = unit(curve - camera_m)
    steps = np.arange(-SIGHT_BEFORE_M, SIGHT_REACH_M, HOLE_RADIUS_M)
    samples = (curve[:, None, :] + steps[None, :, None] * sight[:, None, :]).reshape(-1, 3)
    counts = surface.tree.query_ball_point(samples, HOLE_RADIUS_M, return_length=True)
    return counts.reshape(len(curve), len(steps)).sum(axis=1)
