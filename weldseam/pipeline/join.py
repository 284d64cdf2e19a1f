"""Join: pieces of one seam trimmed where they overlap, joined end to end, loops closed.

Several chains often trace the same seam, each a little further than the others, and a seam often
comes out in pieces (holes in the scan, junctions in the candidate band). Longest first, each
stretch of seam is kept once; open pieces whose ends face each other are joined (never three ends
meeting at a junction; a piece resting only on corners with one face unseen only along the curve
of the other's full fits), through the corner where they turn (a groove over a block's edge)
unless one's end curve bends and leads to the other (a ring, a saddle: _curves_on); a piece
whose own ends meet is a closed loop.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import JoinConfig
from weldseam.geometry import bend_corner, corner_before, polyline_length, unit
from weldseam.pipeline.ends import (
    END_BASELINE_M, NOT_FULL, ahead, end_curve, end_direction, last_full, offsets, on_curve, sideways_reach_m,
)
from weldseam.pipeline.joints import one_joint
from weldseam.pipeline.trace import TracedSeam, end_to_end

# Another piece of the same seam may start this many times as far sideways of the curve one piece's
# end leads along as an extension would take a fit there (ends.sideways_reach_m).
CONTINUE_SLACK = 2.0
# A piece's end curve bending at a radius under this is a curve, not a straight run into a corner.
MAX_CURVE_RADIUS_M = 0.1


def join_seams(seams: list[TracedSeam], params: JoinConfig, step_m: float,
               corner_join_m: float | None = None) -> list[TracedSeam]:
    """The seams trimmed where they overlap, joined (through a corner only within `corner_join_m`;
    None: join_m), and trimmed again (a join may bridge onto a stretch another piece also covers)."""
    joined = join_pieces(trim_overlaps(seams, tolerance_m=params.overlap_m), join_m=params.join_m,
                         max_turn_deg=params.max_turn_deg, step_m=step_m, corner_join_m=corner_join_m)  # fmt: skip
    return trim_overlaps(joined, tolerance_m=params.overlap_m)


def trim_overlaps(seams: list[TracedSeam], *, tolerance_m: float) -> list[TracedSeam]:
    """Keep each stretch of seam once: several chains often trace the same seam, each a
    little further than the others. Longest first, every seam loses the points within
    `tolerance_m` of a seam already kept, or inside a kept groove (in_groove); what remains
    (possibly several runs) is kept."""
    kept: list[TracedSeam] = []
    # One tree per kept seam, over its polyline rather than its points: a joined seam may
    # bridge a gap.
    kept_trees: list[cKDTree] = []

    def keep(piece: TracedSeam) -> None:
        kept.append(piece)
        kept_trees.append(cKDTree(_densified(piece.positions_m, piece.closed, tolerance_m / 2)))

    for seam in sorted(seams, key=lambda s: (-s.length_m, tuple(s.positions_m[0]))):
        covered_by = [
            (tree.query(seam.positions_m)[0] <= tolerance_m) | in_groove(other, seam.positions_m, tolerance_m)
            for tree, other in zip(kept_trees, kept)
        ]
        covered = np.logical_or.reduce(covered_by) if covered_by else np.zeros(len(seam.positions_m), bool)
        if not covered.any():
            keep(seam)
            continue
        # The seam that covers most of it was traced from its candidates too.
        owner = int(np.argmax([np.count_nonzero(c) for c in covered_by]))
        kept[owner] = replace(kept[owner], sources=kept[owner].sources | seam.sources)
        runs = np.split(np.flatnonzero(~covered), np.flatnonzero(np.diff(np.flatnonzero(~covered)) > 1) + 1)
        for run in runs:
            if len(run) >= 2:
                keep(seam.part(run))
    return kept


def in_groove(groove: TracedSeam, points: np.ndarray, tolerance_m: float) -> np.ndarray:
    """(N,) whether each point lies in the groove's open volume: beside its nearest seam point q
    (not beyond the groove's ends: within `tolerance_m` along it), at most the half-opening h
    across, and deeper than `tolerance_m` but no more than 2 h below the opening along the torch
    axis a (a 60-degree V is 1.7 h deep): depth = (p - q) . a. A corner traced at a groove's root,
    or along a wall, is the groove seen by another model, no joint of its own; a branch meeting
    the groove at a Y lies at its surface, and only the distance rule trims it."""
    h = groove.half_opening_m
    inside = np.zeros(len(points), bool)
    if h <= tolerance_m or len(groove.positions_m) < 2:
        return inside
    distance, nearest = cKDTree(groove.positions_m).query(points, distance_upper_bound=2 * h + tolerance_m)
    near = np.isfinite(distance)
    if not near.any():
        return inside
    index = nearest[near]
    travel = np.gradient(groove.positions_m, axis=0)[index]
    travel /= np.maximum(np.linalg.norm(travel, axis=1, keepdims=True), 1e-12)
    offset = points[near] - groove.positions_m[index]
    axis = groove.torch_axes[index]
    depth, along = np.sum(offset * axis, axis=1), np.sum(offset * travel, axis=1)
    across = offset - depth[:, None] * axis - along[:, None] * travel
    inside[near] = ((depth > tolerance_m) & (depth <= 2 * h) & (np.linalg.norm(across, axis=1) <= h)
                    & (np.abs(along) <= tolerance_m))  # fmt: skip
    return inside


def _densified(points: np.ndarray, closed: bool, step_m: float) -> np.ndarray:
    """Points along the polyline through `points`, no more than `step_m` apart."""
    if closed:
        points = np.vstack([points, points[:1]])
    steps = np.maximum(np.ceil(np.linalg.norm(np.diff(points, axis=0), axis=1) / step_m).astype(int), 1)
    fractions = [np.arange(count) / count for count in steps]
    starts, ends = points[:-1], points[1:]
    dense = [start + np.outer(f, end - start) for start, end, f in zip(starts, ends, fractions)]
    return np.vstack([*dense, points[-1:]]) if dense else points


def join_pieces(
    seams: list[TracedSeam], *, join_m: float, max_turn_deg: float, step_m: float, corner_join_m: float | None = None
) -> list[TracedSeam]:
    """Join pieces of one seam and close loops.

    Two open pieces of one joint (joints.one_joint: the same kind, or one a special case of the
    other; the joined seam takes the kind of the piece with more points) are joined when an end
    of one and an end of the other are within `join_m`, face each other (their outward directions differ from opposite by
    less than `max_turn_deg`, so a groove turning over a block edge stays one seam) and the
    gap runs along their mean direction (within 60 degrees); pieces joined straight must continue
    each other (_continues: `step_m` is the extension's step); pieces joined through a corner lie
    within `corner_join_m` (None: join_m). Where a third seam also ends (the
    junction of a Y or T) nothing is joined: the branches stay separate seams. An open seam whose own ends meet that way is a closed loop.
    """
    pieces = sorted(seams, key=lambda s: (-len(s.positions_m), tuple(s.positions_m[0])))
    cos_turn = np.cos(np.radians(max_turn_deg))
    cos_along = np.cos(np.radians(min(max_turn_deg, 60.0)))
    corner_join_m = join_m if corner_join_m is None else corner_join_m
    while True:
        # The closest feasible join first, so a small piece inside a gap is joined before
        # the gap is bridged past it.
        best = None
        for i in range(len(pieces)):
            for j in range(i + 1, len(pieces)):
                first, second = pieces[i], pieces[j]
                if first.closed or second.closed or not one_joint(first.joint, second.joint):
                    continue
                others = [piece for k, piece in enumerate(pieces) if k not in (i, j)]
                candidate = _joined(first, second, join_m, corner_join_m, cos_turn, cos_along, others, step_m)
                if candidate is not None and (best is None or candidate[0] < best[0]):
                    best = (candidate[0], i, j, candidate[1])
        if best is None:
            break
        _, i, j, merged = best
        pieces[i] = merged
        pieces.pop(j)
    return [_closed_if_ends_meet(piece, join_m, cos_along) for piece in pieces]


def _joined(
    first: TracedSeam, second: TracedSeam, join_m: float, corner_join_m: float, cos_turn: float, cos_along: float,
    others: list[TracedSeam], step_m: float,
) -> tuple[float, TracedSeam] | None:
    """(gap, joined seam) for the closest way to join two pieces end to end (join_m and
    corner_join_m as join_pieces), or None."""
    best = None
    # Whether each piece has a direction of its own does not depend on which way it runs.
    a_directed, b_directed = _directed(first.positions_m), _directed(second.positions_m)
    for first_way in (first, first.reversed()):
        for second_way in (second, second.reversed()):
            a, b = first_way.positions_m, second_way.positions_m
            gap = b[0] - a[-1]
            distance = float(np.linalg.norm(gap))
            if distance > join_m or (best is not None and distance >= best[0]):
                continue
            out_a, out_b = end_direction(a, at_start=False), end_direction(b, at_start=True)
            # A piece without a direction of its own (_directed) faces any way.
            facing = not (a_directed and b_directed) or -out_a @ out_b >= cos_turn
            # Through a bend the gap runs along the mean of the two directions; a piece without
            # a direction of its own defers to the other.
            if not a_directed:
                reference = -out_b
            elif not b_directed:
                reference = out_a
            else:
                reference = unit(out_a - out_b)
            along = distance < 1e-3 or unit(gap) @ reference >= cos_along
            if not (facing and along) or _junction((a[-1] + b[0]) / 2, others, join_m) \
                    or not _inferred_follows(first_way, second_way):
                continue
            leads = _leads(first_way, second_way)
            corner = None if _curves_on(leads, step_m) else _corner(a, out_a, b, out_b, join_m)
            if corner is not None and distance > corner_join_m:
                continue
            if corner is None and not _continues(leads, max(first.across_spread, second.across_spread), step_m):
                continue
            between = (np.empty((0, 3)), np.empty((0, 3)), np.empty(0, np.uint8)) if corner is None else \
                (corner[None], unit(first_way.torch_axes[-1] + second_way.torch_axes[0])[None], np.zeros(1, np.uint8))
            best = (distance, end_to_end(first_way, between, second_way))
    return best


def _continues(leads: list[tuple[float, float, float]], spread: float, step_m: float) -> bool:
    """Whether two pieces joined straight continue each other: b's start lies where a's end curve
    leads (ends.ahead over the gap between them), and a's end where b's start curve leads back
    (`leads`: _leads), each within CONTINUE_SLACK x what an extension stepping `step_m` takes
    across the gap (ends.sideways_reach_m) sideways of the torch axis, widened by the pieces'
    larger across_spread (`spread`): a piece's end curve, its bend read over its last few points,
    may miss by that much across a wider gap. A piece without a direction of its own (_directed)
    defers to the other. Beside a tack weld, a chain on its edge fits a groove 3-4 mm off the seam
    over 20 mm, its line turned 25 degrees from the seam's, and its curve misses the seam's end by
    10 mm: no piece of it."""
    return all(sideways <= CONTINUE_SLACK * (sideways_reach_m(step_m, distance) * spread)
               for sideways, distance, _ in leads)


def _curves_on(leads: list[tuple[float, float, float]], step_m: float) -> bool:
    """Whether b's start lies where a's end curve leads, or a's end where b's start curve leads
    back (`leads`: _leads), a curve bending at a radius under MAX_CURVE_RADIUS_M, within what an
    extension stepping `step_m` takes across the gap (ends.sideways_reach_m): a ring's or a
    saddle's pieces, which straight rays would join through a corner off the seam."""
    return any(bend * MAX_CURVE_RADIUS_M >= 1.0 and sideways <= sideways_reach_m(step_m, distance)
               for sideways, distance, bend in leads)


def _leads(a: TracedSeam, b: TracedSeam) -> list[tuple[float, float, float]]:
    """For a's end toward b's start, and b's start back toward a's end, each of a piece with a
    direction of its own (_directed): how far (m) the other's facing end lies sideways of the torch
    axis from where this end's curve leads (ends.ahead over the gap: ends.offsets), the gap (m) and
    the curve's bend (1/m)."""
    leads = []
    for before, after in ((a, b), (b.reversed(), a.reversed())):
        if not _directed(before.positions_m):
            continue
        last = before.positions_m[-1]
        direction, bend = end_curve(before.positions_m)
        target = after.positions_m[0]
        distance = float(np.linalg.norm(target - last))
        predicted, travel = ahead(last, direction, bend, distance)
        _, sideways = offsets(target, predicted, travel, before.torch_axes[-1])
        leads.append((sideways, distance, float(np.linalg.norm(bend))))
    return leads


def _inferred_follows(a: TracedSeam, b: TracedSeam) -> bool:
    """Whether b may go on from a's end as far as inferred fits go: a piece none of whose points
    rests on a full fit (ends.NOT_FULL: corners with one face unseen, outlines that miss the
    points) goes on from a piece with full fits only along the curve at its last such fit
    (ends.on_curve), as an extension's inferred fits do. Past a standing pipe's silhouette the edge
    of its shadow passes for a corner with one face unseen, and runs straight off the ring along
    the line of sight; past a plate's end a loose bar lying against it gives rough grooves in line
    with the seam, then off it."""
    for measured, inferred in ((a, b), (b.reversed(), a.reversed())):
        full = last_full(measured.positions_m, measured.point_flags)
        if not full or np.any((inferred.point_flags & NOT_FULL) == 0):
            continue
        index, direction, bend, scatter = full
        start = polyline_length(measured.positions_m[index:])
        steps = np.linalg.norm(np.diff(np.vstack([measured.positions_m[-1:], inferred.positions_m]), axis=0), axis=1)
        axis = measured.torch_axes[-1]
        if not all(on_curve(measured.positions_m[index], direction, bend, start + arc, point, axis, scatter)
                   for arc, point in zip(np.cumsum(steps), inferred.positions_m)):  # fmt: skip
            return False
    return True


def _corner(a: np.ndarray, out_a: np.ndarray, b: np.ndarray, out_b: np.ndarray, join_m: float):
    """The bend between piece a's end and piece b's start, or None for a straight bridge: where
    both carried straight on meet, or, when one has no direction of its own, where the
    other turns to reach it."""
    a_directed, b_directed = _directed(a), _directed(b)
    if a_directed and b_directed:
        return bend_corner(a[-1], out_a, b[0], out_b, join_m)
    if a_directed:
        return corner_before(a[-1], out_a, b[0])
    if b_directed:
        return corner_before(b[0], out_b, a[-1])
    return None


def _directed(points: np.ndarray) -> bool:
    """Whether a piece (K, 3) has a direction of its own: its ends END_BASELINE_M apart, or its
    polyline twice that long (a ring's piece nearly closed). A polyline barely that long whose
    ends are not zigzags: a 3-point piece whose middle point lies 6 mm off (12.8 mm of polyline
    over 4.5 mm) has a "direction" across the seam, and was joined on far end first."""
    return bool(np.linalg.norm(points[-1] - points[0]) >= END_BASELINE_M
                or polyline_length(points) >= 2 * END_BASELINE_M)


def _junction(point: np.ndarray, others: list[TracedSeam], join_m: float) -> bool:
    """True when a third seam (at least a direction baseline long) also ends within
    `join_m` of `point`: three ends meet at a Y or T, and no two of them are one seam."""
    return any(
        min(np.linalg.norm(other.positions_m[0] - point), np.linalg.norm(other.positions_m[-1] - point)) <= join_m
        for other in others
        if not other.closed and polyline_length(other.positions_m) >= END_BASELINE_M
    )


def _closed_if_ends_meet(seam: TracedSeam, join_m: float, cos_turn: float) -> TracedSeam:
    points = seam.positions_m
    if seam.closed or len(points) < 8:
        return seam
    gap = points[0] - points[-1]
    length = seam.length_m
    out_end, out_start = end_direction(points, at_start=False), end_direction(points, at_start=True)
    meets = np.linalg.norm(gap) <= join_m and -out_end @ out_start >= cos_turn and length > 4 * join_m
    if not meets:
        return seam
    return seam.part(slice(None), closed=True)
