"""Split: the final seams, one per branch at T and Y junctions, with the holes each crossed.

Fragments that joined nothing are noise, and a piece too short to be a seam (of any kind, or of its
own: joints.min_length_m) is no branch: they are dropped before splitting (one would be dropped
after splitting a real seam, leaving it in two). A kind's shortest length is counted along its
longest stretch between sharp corners (straight_length_m): a lap or an outside corner runs along a
plate's edge, while the outline of a clamp's arm on a plate, a step of a lap plate's height, turns
round the arm's end in 20-30 mm stretches. A seam is split
where another seam ends on its interior; the pieces each carry the holes in the scan whose middle
lies on them.

A seam none of whose sections was a clean fit (every point rests on a corner with one face unseen,
a rough outline, a bridge or an interpolation: section.PointFlag) is inferred, never measured: the
edge of a tall object's shadow passes for a corner with its wall unseen, and a clamp's jaw or a
bar's end gives rough fits over its 20-40 mm. Such a seam is kept only when it runs on as a part's
edge does, over split.min_inferred_length_m, and when the joint's outline misses the section's
points (ROUGH) at no more than MAX_ROUGH_SHARE of them: the corner inferred from a face's end rests
on that face's fit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import SplitConfig
from weldseam.geometry import arc_lengths
from weldseam.pipeline.joints import min_length_m
from weldseam.pipeline.section import PointFlag
from weldseam.pipeline.trace import Hole, TracedSeam

# A corner is where a seam turns by more than SHARP_TURN_DEG between its chords of CORNER_CHORD_M
# before and after a point: a plate's or an arm's corner, rounded by a few mm, turns 90 degrees;
# an arc turns that much only at radii under CORNER_CHORD_M / radians(SHARP_TURN_DEG) = 13 mm,
# and noise of 0.3 mm across turns a 10 mm chord by 2-3 degrees.
SHARP_TURN_DEG = 45.0
CORNER_CHORD_M = 0.010
# An inferred seam rough at more of its points than this is not explained by its joint: the
# spurious corners of broad scenes (a bar's foot past its shadow, a lying pipe's flank, a post's
# side) were rough at 76-100 % of their points, T-joints seen from above (their web's face unseen
# all along, our own and independent frames) at up to 58 %.
MAX_ROUGH_SHARE = 2 / 3


def split_seams(seams: list[TracedSeam], holes: list[Hole], params: SplitConfig, step_m: float) -> list[TracedSeam]:
    """The seams without fragments, split at junctions, each seen over min_seam_length_m (what was
    interpolated across holes does not count), no shorter than its kind's shortest seam
    (joints.min_length_m), clean somewhere or no shorter than min_inferred_length_m and explained
    (see the module's docstring), and with the holes whose middle lies within `step_m` (the spacing
    of the points bridged across them) of one of its points."""
    seams = [seam for seam in seams
             if seam.length_m >= max(params.min_branch_m, params.min_seam_length_m) and long_enough(seam)]
    seams = split_at_junctions(seams, tolerance_m=params.junction_m)
    return [_with_holes(seam, holes, step_m) for seam in seams
            if seen_length(seam) >= params.min_seam_length_m and long_enough(seam)
            and (measured(seam) or (seam.length_m >= params.min_inferred_length_m and explained(seam)))]


def long_enough(seam: TracedSeam) -> bool:
    """Whether the seam is no shorter than its kind's shortest seam (joints.min_length_m) along its
    longest stretch between sharp corners (straight_length_m)."""
    shortest = min_length_m(seam.joint)
    return shortest == 0 or (seam.length_m >= shortest and straight_length_m(seam) >= shortest)


def straight_length_m(seam: TracedSeam) -> float:
    """Arc length (m) of the seam's longest stretch between corners, each corner at the sharpest
    point of a run of points whose chords CORNER_CHORD_M long before and after them turn by more
    than SHARP_TURN_DEG (a loop's stretches run on across its closing segment; with no corner,
    its whole length)."""
    along = arc_lengths(seam.positions_m, seam.closed)
    total = float(along[-1])
    points = np.vstack([seam.positions_m, seam.positions_m[:1]]) if seam.closed else seam.positions_m
    here = along[:-1] if seam.closed else along  # each seam point's arc length
    period = total if seam.closed else None

    def at(s: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(s, along, points[:, k], period=period) for k in range(3)])

    middle = seam.positions_m
    incoming, outgoing = middle - at(here - CORNER_CHORD_M), at(here + CORNER_CHORD_M) - middle
    lengths = np.linalg.norm(incoming, axis=1) * np.linalg.norm(outgoing, axis=1)
    cosine = np.sum(incoming * outgoing, axis=1) / np.maximum(lengths, 1e-12)
    turning = cosine < np.cos(np.radians(SHARP_TURN_DEG))
    if not seam.closed:
        turning &= (here >= CORNER_CHORD_M) & (here <= total - CORNER_CHORD_M)
    index = np.flatnonzero(turning)
    runs = np.split(index, np.flatnonzero(np.diff(index) > 1) + 1)
    corners = np.array([here[run[np.argmin(cosine[run])]] for run in runs if len(run)])
    if not len(corners):
        return total
    bounds = np.r_[corners, corners[0] + total] if seam.closed else np.r_[0.0, corners, total]
    return float(np.diff(bounds).max())


def seen_length(seam: TracedSeam) -> float:
    """Arc length (m) of the seam's segments whose two ends were seen (not interpolated across a hole)."""
    points = np.vstack([seam.positions_m, seam.positions_m[:1]]) if seam.closed else seam.positions_m
    flags = np.r_[seam.point_flags, seam.point_flags[:1]] if seam.closed else seam.point_flags
    seen = (flags & PointFlag.INTERPOLATED) == 0
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    return float(steps[seen[:-1] & seen[1:]].sum())


def measured(seam: TracedSeam) -> bool:
    """Whether any point of the seam rests on a clean fit of its section (no PointFlag bit)."""
    return bool(np.any(seam.point_flags == 0))


def explained(seam: TracedSeam) -> bool:
    """Whether the joint's outline misses the section's points (PointFlag.ROUGH) at no more than
    MAX_ROUGH_SHARE of the seam's points."""
    return bool(np.count_nonzero(seam.point_flags & PointFlag.ROUGH) <= MAX_ROUGH_SHARE * len(seam.point_flags))


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
            head, tail = seam.part(slice(None, cut + 1)), seam.part(slice(cut, None))
            result[index : index + 1] = [head, tail]
            changed = True
            break
    return result


def _with_holes(seam: TracedSeam, holes: list[Hole], reach_m: float) -> TracedSeam:
    """The seam with the holes (crossed by any extension) whose middle lies on it, within a step
    of one of its points. Pieces of one seam often cross the same hole: longest first, a hole whose
    middle lies within half a kept one's length of that one's middle is the same hole."""
    if not holes:
        return seam
    seam_tree = cKDTree(seam.positions_m)
    kept: list[Hole] = []
    for hole in sorted(holes, key=lambda h: (-h.length_m, h.middle_m)):
        middle = np.array(hole.middle_m)
        if seam_tree.query(middle)[0] > reach_m:
            continue
        if all(np.linalg.norm(middle - np.array(other.middle_m)) > other.length_m / 2 for other in kept):
            kept.append(hole)
    return replace(seam, holes=tuple(kept))
