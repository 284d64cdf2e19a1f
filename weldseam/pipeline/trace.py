"""Tracing: turn coarse ordered chains into seams via cross-sections.

A chain's sections are fitted; the seam's joint is the kind most sections agree on, and
a chain where fewer than `min_valid_fraction` of the sections fit that joint is not a seam
(plate outer edges, table edges, steps, noise). Runs of failed sections longer than
`max_gap_m` split the seam. The traced pieces are then trimmed where they overlap, joined,
extended section by section to the seam's real ends (never its end caps), and split at
T/Y junctions.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from weldseam.geometry import unit
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import FILLET, analyse_sections, section_frames


PROBE_SECTIONS = 3


@dataclass(frozen=True)
class TracedSeam:
    """Seam points (K, 3) and torch axes (K, 3) in travel order."""

    positions_m: np.ndarray
    torch_axes: np.ndarray
    closed: bool
    joint: str
    confidence: float


def assemble_seams(
    traced: list[TracedSeam],
    points: np.ndarray,
    tree,
    *,
    support,
    support_tolerance_m: float,
    overlap_m: float,
    join_m: float,
    max_turn_deg: float,
    min_branch_m: float,
    min_seam_length_m: float,
    step_m: float,
    max_gap_m: float,
    max_extension_m: float,
    section_params: dict,
) -> list[TracedSeam]:
    """The final seams from every chain's traces: fillets on the support plane dropped,
    overlaps trimmed, pieces joined, open ends extended (then trimmed and joined again,
    since extensions may meet), fragments dropped, T/Y junctions split."""

    def trimmed_and_joined(seams: list[TracedSeam]) -> list[TracedSeam]:
        joined = join_pieces(trim_overlaps(seams, tolerance_m=overlap_m), join_m=join_m, max_turn_deg=max_turn_deg)
        return trim_overlaps(joined, tolerance_m=overlap_m)

    seams = trimmed_and_joined(off_support(traced, support, support_tolerance_m))
    seams = trimmed_and_joined([
        extend_seam(
            seam, points, tree, step_m=step_m, max_gap_m=max_gap_m, max_extension_m=max_extension_m,
            section_params=section_params,
        )
        for seam in seams
    ])
    # Fragments that joined nothing are noise; they must not split real seams either.
    seams = [seam for seam in seams if seam_length(seam) >= min_branch_m]
    seams = split_at_junctions(seams, tolerance_m=join_m / 2)
    return [seam for seam in seams if seam_length(seam) >= min_seam_length_m]


def trace_chain(
    chain: Chain,
    approx_axes: np.ndarray,
    points: np.ndarray,
    tree,
    *,
    step_m: float,
    max_gap_m: float,
    min_valid_fraction: float,
    section_params: dict,
) -> list[TracedSeam]:
    """Seams found along one chain (none if the chain is not a seam).

    Three evenly spaced sections are fitted first; when none of them fits a joint the
    chain is rejected without fitting the rest (most candidates are plate or table edges).
    """
    travel, axes, lateral = section_frames(chain.points, approx_axes, chain.closed)
    probes = np.unique(np.linspace(0, len(chain.points) - 1, PROBE_SECTIONS).round().astype(int))
    probe_fits = analyse_sections(points, tree, chain.points[probes], travel[probes], axes[probes], lateral[probes], **section_params)
    if not any(fit.joint for fit in probe_fits):
        return []
    fits = analyse_sections(points, tree, chain.points, travel, axes, lateral, **section_params)
    kinds = Counter(fit.joint for fit in fits if fit.joint)
    if not kinds:
        return []
    joint, count = max(sorted(kinds.items()), key=lambda item: item[1])
    confidence = count / len(fits)
    if confidence < min_valid_fraction:
        return []
    valid = np.array([fit.joint == joint for fit in fits]) & _consistent([fit.point_m for fit in fits], step_m)
    seams = []
    for run, closed in _valid_runs(chain.points, valid, chain.closed, max_gap_m):
        run_fits = [fits[i] for i in run]
        seams.append(
            TracedSeam(
                positions_m=np.array([fit.point_m for fit in run_fits]),
                torch_axes=np.array([fit.torch_axis for fit in run_fits]),
                closed=closed,
                joint=joint,
                confidence=round(confidence, 3),
            )
        )
    return seams


def _consistent(seam_points: list[np.ndarray], step_m: float) -> np.ndarray:
    """False for seam points that jump off the line of their neighbours: farther than
    max(1 mm, 2 steps) from the median of the 5 sections around them."""
    positions = np.asarray(seam_points)
    if len(positions) < 5:
        return np.ones(len(positions), bool)
    padded = np.pad(positions, ((2, 2), (0, 0)), mode="edge")
    windows = np.stack([padded[k : k + len(positions)] for k in range(5)], axis=1)
    deviation = np.linalg.norm(positions - np.median(windows, axis=1), axis=1)
    return deviation <= max(0.001, 2 * step_m)


def _valid_runs(centres: np.ndarray, valid: np.ndarray, closed: bool, max_gap_m: float):
    """Index runs of valid sections, split where the valid ones are more than max_gap_m apart."""
    indices = np.flatnonzero(valid)
    if len(indices) < 2:
        return []
    gaps = np.linalg.norm(np.diff(centres[indices], axis=0), axis=1)
    breaks = np.flatnonzero(gaps > max_gap_m) + 1
    runs = np.split(indices, breaks)
    if closed:
        wrap_gap = np.linalg.norm(centres[indices[0]] - centres[indices[-1]])
        if len(runs) == 1 and wrap_gap <= max_gap_m:
            return [(runs[0], True)]
        if len(runs) > 1 and wrap_gap <= max_gap_m:
            runs = [np.concatenate([runs[-1], runs[0]])] + runs[1:-1]
    return [(run, False) for run in runs if len(run) >= 2]


def extend_seam(
    seam: TracedSeam, points, tree, *, step_m: float, max_gap_m: float, max_extension_m: float, section_params: dict
) -> TracedSeam:
    """The seam with sections added beyond both open ends while they fit its joint near
    the predicted place, so the path reaches the seam's real ends.

    A section that fails (a hole, a spatter blob) is stepped over; the extension stops after
    `max_gap_m` without a fit. A fit counts when it lies within max(1.5 steps, 15 % of the
    distance from the last fit) of the straight-line prediction sideways (the fit is a
    verified joint profile and the better estimate: near an end the prediction drifts by
    1-3 mm; the bound follows curves of radius down to ~40 mm across the largest gap), and
    within half a step along the torch axis (the surface does not jump; a section that
    straddles the part's end face does). Run on joined seams only: extending every
    partial trace would walk the same seam once per piece.
    """
    if seam.closed or len(seam.positions_m) < 2:
        return seam
    positions, axes = list(seam.positions_m), list(seam.torch_axes)
    for at_start in (True, False):
        if at_start:
            positions.reverse()
            axes.reverse()
        direction = _end_direction(np.array(positions), at_start=False)
        last_point, last_axis = positions[-1], axes[-1]
        for _ in range(int(max_extension_m / step_m)):
            distance = step_m
            while distance <= max_gap_m:
                predicted = last_point + distance * direction
                axis = unit(last_axis[None] - (last_axis @ direction) * direction[None])
                fit = analyse_sections(
                    points, tree, predicted[None], direction[None], axis, np.cross(direction[None], axis),
                    **section_params,
                )[0]
                offset = fit.point_m - predicted
                depth = abs(offset @ axis[0])
                sideways = np.linalg.norm(offset - (offset @ axis[0]) * axis[0])
                if fit.joint == seam.joint and sideways <= max(1.5 * step_m, 0.15 * distance) and depth <= 0.5 * step_m:
                    break
                distance += step_m
            else:
                break
            positions.append(fit.point_m)
            axes.append(fit.torch_axis)
            # Re-aim along the last 12 mm: one 2 mm step alone is ~10 degrees noisy.
            direction = _end_direction(np.array(positions), at_start=False)
            last_point, last_axis = fit.point_m, fit.torch_axis
        if at_start:
            positions.reverse()
            axes.reverse()
    return TracedSeam(np.array(positions), np.array(axes), False, seam.joint, seam.confidence)


def off_support(seams: list[TracedSeam], support, tolerance_m: float) -> list[TracedSeam]:
    """The seams that are not fillets on the support plane (`support` = (point, normal) or
    None): there a part stands on the table."""
    if support is None:
        return seams
    centre, normal = support
    return [
        seam
        for seam in seams
        if seam.joint != FILLET or np.median(np.abs((seam.positions_m - centre) @ normal)) > tolerance_m
    ]


def trim_overlaps(seams: list[TracedSeam], *, tolerance_m: float) -> list[TracedSeam]:
    """Keep each stretch of seam once: several chains often trace the same seam, each a
    little further than the others. Longest first, every seam loses the points within
    `tolerance_m` of a seam already kept; what remains (possibly several runs) is kept."""
    kept: list[TracedSeam] = []
    for seam in sorted(seams, key=lambda s: (-seam_length(s), tuple(s.positions_m[0]))):
        covered = np.zeros(len(seam.positions_m), bool)
        for other in kept:
            # Against the polyline, not just its points: a joined seam may bridge a gap.
            dense = _densified(other.positions_m, other.closed, tolerance_m / 2)
            covered |= cKDTree(dense).query(seam.positions_m)[0] <= tolerance_m
        if not covered.any():
            kept.append(seam)
            continue
        runs = np.split(np.flatnonzero(~covered), np.flatnonzero(np.diff(np.flatnonzero(~covered)) > 1) + 1)
        kept += [
            TracedSeam(seam.positions_m[run], seam.torch_axes[run], False, seam.joint, seam.confidence)
            for run in runs
            if len(run) >= 2
        ]
    return kept


def _densified(points: np.ndarray, closed: bool, step_m: float) -> np.ndarray:
    """Points along the polyline through `points`, no more than `step_m` apart."""
    if closed:
        points = np.vstack([points, points[:1]])
    steps = np.maximum(np.ceil(np.linalg.norm(np.diff(points, axis=0), axis=1) / step_m).astype(int), 1)
    fractions = [np.arange(count) / count for count in steps]
    starts, ends = points[:-1], points[1:]
    dense = [start + np.outer(f, end - start) for start, end, f in zip(starts, ends, fractions)]
    return np.vstack([*dense, points[-1:]]) if dense else points


def seam_length(seam: TracedSeam) -> float:
    """Arc length (m), including the closing segment of a loop."""
    points = np.vstack([seam.positions_m, seam.positions_m[:1]]) if seam.closed else seam.positions_m
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def join_pieces(seams: list[TracedSeam], *, join_m: float, max_turn_deg: float) -> list[TracedSeam]:
    """Join pieces of one seam and close loops.

    Two open pieces of the same joint are joined when an end of one and an end of the other
    are within `join_m`, face each other (their outward directions differ from opposite by
    less than `max_turn_deg`, so a groove turning over a block edge stays one seam) and the
    gap runs along their mean direction (within 60 degrees). Where a third seam also ends (the
    junction of a Y or T) nothing is joined: the branches stay separate seams. An open seam whose own ends meet that way is a closed loop.
    """
    pieces = sorted(seams, key=lambda s: (-len(s.positions_m), tuple(s.positions_m[0])))
    cos_turn = np.cos(np.radians(max_turn_deg))
    cos_along = np.cos(np.radians(min(max_turn_deg, 60.0)))
    while True:
        # The closest feasible join first, so a small piece inside a gap is joined before
        # the gap is bridged past it.
        best = None
        for i in range(len(pieces)):
            for j in range(i + 1, len(pieces)):
                first, second = pieces[i], pieces[j]
                if first.closed or second.closed or first.joint != second.joint:
                    continue
                others = [piece for k, piece in enumerate(pieces) if k not in (i, j)]
                candidate = _joined(first, second, join_m, cos_turn, cos_along, others)
                if candidate is not None and (best is None or candidate[0] < best[0]):
                    best = (candidate[0], i, j, candidate[1])
        if best is None:
            break
        _, i, j, merged = best
        pieces[i] = merged
        pieces.pop(j)
    return [_closed_if_ends_meet(piece, join_m, cos_along) for piece in pieces]


END_BASELINE_M = 0.012


def _end_direction(points: np.ndarray, at_start: bool) -> np.ndarray:
    """Outward unit direction at one end: the principal direction of the points within
    ~12 mm of arc from the end, pointing out (the last few points alone are too noisy)."""
    ordered = points if at_start else points[::-1]
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ordered, axis=0), axis=1))])
    k = max(1, min(int(np.searchsorted(arc, END_BASELINE_M)), len(ordered) - 1))
    chord = ordered[0] - ordered[k]
    window = ordered[: k + 1] - ordered[: k + 1].mean(axis=0)
    direction = np.linalg.svd(window, full_matrices=False)[2][0] if k >= 2 else chord
    return unit(direction if direction @ chord >= 0 else -direction)


def _joined(
    first: TracedSeam, second: TracedSeam, join_m: float, cos_turn: float, cos_along: float, others: list[TracedSeam]
) -> tuple[float, TracedSeam] | None:
    """(gap, joined seam) for the closest way to join two pieces end to end, or None."""
    best = None
    for first_reversed in (False, True):
        for second_reversed in (False, True):
            a = first.positions_m[::-1] if first_reversed else first.positions_m
            b = second.positions_m[::-1] if second_reversed else second.positions_m
            gap = b[0] - a[-1]
            distance = float(np.linalg.norm(gap))
            if distance > join_m or (best is not None and distance >= best[0]):
                continue
            out_a, out_b = _end_direction(a, at_start=False), _end_direction(b, at_start=True)
            # A piece shorter than the direction baseline has no direction of its own.
            facing = _length(b) < END_BASELINE_M or _length(a) < END_BASELINE_M or -out_a @ out_b >= cos_turn
            # Through a bend the gap runs along the mean of the two directions; a piece too
            # short to have a direction defers to the other.
            if _length(a) < END_BASELINE_M:
                reference = -out_b
            elif _length(b) < END_BASELINE_M:
                reference = out_a
            else:
                reference = unit(out_a - out_b)
            along = distance < 1e-3 or unit(gap) @ reference >= cos_along
            if not (facing and along) or _junction((a[-1] + b[0]) / 2, others, join_m):
                continue
            axes_a = first.torch_axes[::-1] if first_reversed else first.torch_axes
            axes_b = second.torch_axes[::-1] if second_reversed else second.torch_axes
            weight = len(a) / (len(a) + len(b))
            best = (distance, TracedSeam(
                positions_m=np.vstack([a, b]),
                torch_axes=np.vstack([axes_a, axes_b]),
                closed=False,
                joint=first.joint,
                confidence=round(weight * first.confidence + (1 - weight) * second.confidence, 3),
            ))
    return best


def _length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def split_at_junctions(seams: list[TracedSeam], *, tolerance_m: float) -> list[TracedSeam]:
    """Split a seam where another seam ends on its interior (a T or Y junction): each
    branch becomes its own seam, meeting at the junction."""
    result = list(seams)
    changed = True
    while changed:
        changed = False
        for index, seam in enumerate(result):
            if len(seam.positions_m) < 4:
                continue
            ends = [piece.positions_m[k] for other, piece in enumerate(result) if other != index for k in (0, -1)]
            if not ends:
                continue
            distance, nearest = cKDTree(seam.positions_m).query(np.array(ends))
            inner = (distance <= tolerance_m) & (nearest >= 2) & (nearest <= len(seam.positions_m) - 3)
            if seam.closed or not inner.any():
                continue
            cut = int(nearest[inner][0])
            head = TracedSeam(seam.positions_m[: cut + 1], seam.torch_axes[: cut + 1], False, seam.joint, seam.confidence)
            tail = TracedSeam(seam.positions_m[cut:], seam.torch_axes[cut:], False, seam.joint, seam.confidence)
            result[index : index + 1] = [head, tail]
            changed = True
            break
    return result


def _junction(point: np.ndarray, others: list[TracedSeam], join_m: float) -> bool:
    """True when a third seam (at least a direction baseline long) also ends within
    `join_m` of `point`: three ends meet at a Y or T, and no two of them are one seam."""
    return any(
        min(np.linalg.norm(other.positions_m[0] - point), np.linalg.norm(other.positions_m[-1] - point)) <= join_m
        for other in others
        if not other.closed and _length(other.positions_m) >= END_BASELINE_M
    )


def _closed_if_ends_meet(seam: TracedSeam, join_m: float, cos_turn: float) -> TracedSeam:
    points = seam.positions_m
    if seam.closed or len(points) < 8:
        return seam
    gap = points[0] - points[-1]
    length = seam_length(seam)
    out_end, out_start = _end_direction(points, at_start=False), _end_direction(points, at_start=True)
    meets = np.linalg.norm(gap) <= join_m and -out_end @ out_start >= cos_turn and length > 4 * join_m
    if not meets:
        return seam
    return TracedSeam(points, seam.torch_axes, True, seam.joint, seam.confidence)
