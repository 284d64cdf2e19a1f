"""Crossing a hole in the scan over the whole seam: the seam is carried across when it fits again
beyond, and the stretch in between is interpolated."""

from __future__ import annotations

import numpy as np

from weldseam.geometry import arc_lengths, polyline_length, unit
from weldseam.pipeline.bridge import groove_bottom, sees_past_end
from weldseam.pipeline.ends import CORNER_PAST_M, ahead, end_curve, offsets
from weldseam.pipeline.joints import ON_SURFACE, JointGeometry, JointKind, one_joint, recentred
from weldseam.pipeline.section import RECENTRE_M, FineSurface, PointFlag, SectionFit
from weldseam.pipeline.seek import Extension, next_fit, plain_fit
from weldseam.pipeline.trace import Hole

# The seam must fit this many times in a row beyond a hole, on data at least a slab apart (or up to
# the part's end), and the seam line across it hold no more than HOLE_STRAYS points within
# HOLE_RADIUS_M (across_hole).
HOLE_CONFIRM = 2
HOLE_RADIUS_M = 0.0015
HOLE_STRAYS = 2
# A stretch whose lines of sight meet a surface this much nearer to the camera (more than
# HOLE_STRAYS of its points) is hidden behind something, a clamp or a bar over the seam, not lost
# in a hole: a torch sent along it would run into what hides it.
OCCLUDER_MARGIN_M = 0.005
# A fit beyond a hole is the seam within this share of its distance ahead sideways of an aim's
# prediction (and DEPTH_SHARE in depth).
SIDEWAYS_SHARE = 0.25
DEPTH_SHARE = 0.05
# A hole's edge cuts the sections beside it short (one groove wall seen, the other not), so the
# fits within this much arc of it may lean sideways: a hole is aimed across from the fits before.
HOLE_EDGE_M = 0.006


def hole_aim(fitted: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(origin, direction, bend) of a curve to seek the seam along across a hole after the
    `fitted` seam points (travel order): from the last of them more than HOLE_EDGE_M of arc
    before the end, along the seam's curve there (end_curve of the fits up to it); None when
    fewer than three fits lie before the edge."""
    arc = arc_lengths(fitted[::-1])
    before = fitted[: len(fitted) - int(np.searchsorted(arc, HOLE_EDGE_M, side="right"))]
    return (before[-1], *end_curve(before)) if len(before) >= 3 else None


def hole_aims(last_point, direction, bend, fitted: np.ndarray, reach_m: float) -> list:
    """The aims (origin, direction, bend) to seek the seam along across a hole after `last_point`:
    the end's curve (`direction`, `bend`) and the curve from before the hole's edge (hole_aim); where
    these two disagree by more than SIDEWAYS_SHARE of `reach_m` at that distance ahead (no fit
    beyond could match both), their bend is no seam's, and their tangents are the aims, straight.
    A bend fitted near an end (up to 1 / ends.MIN_BEND_RADIUS_M) moves its prediction d^2 / 2R
    sideways, 27 mm at 40 mm ahead, where a straight seam goes straight on; and the curve across
    the hole leaves along the aim."""
    curves = [aim for aim in ((last_point, direction, bend), hole_aim(fitted)) if aim is not None]
    if len(curves) < 2:
        return curves
    (first, _), (second, _) = _predictions(curves, _leads(last_point, curves), reach_m)
    if np.linalg.norm(first - second) <= SIDEWAYS_SHARE * reach_m:
        return curves
    return [(origin, tangent, np.zeros(3)) for origin, tangent, _ in curves]


def across_hole(extension: Extension, last_point, last_axis, aims) -> list[SectionFit] | None:
    """Bridged points across a hole in the scan after `last_point` followed by the first
    HOLE_CONFIRM fits beyond it, or None.

    Sections are tried from max_skip_m to max_hole_m ahead of the end along the curve of each of
    `aims` in turn (origin, direction, bend: ends.ahead from the origin, the end's distance from
    it added). The first section that fits the joint (and is no other kind's, fitted for every
    joint: _same_joint) within SIDEWAYS_SHARE of its distance sideways and DEPTH_SHARE in depth of
    any aim's prediction (the fits at a hole's edge may lean, and the aim from before them finds
    the seam where the end's own tangent misses it: hole_aim; an inside corner's with both faces
    seen: _measured) must be followed by HOLE_CONFIRM - 1 more fits in a row, the first and the last
    at least a section's slab apart (sections a step apart share a third of their slabs' points: a
    strip 1.4 mm wide beyond a hole, nothing past it, gave two fits), or by the part's
    end (_part_ends_after): a hole can reach to within a section or two of the plate's end, and
    the scan then sees past the plate right after the fits (a stray fit inside a longer hole has
    nothing after it). The hole is bridged by a cubic
    Hermite curve between the two ends, leaving along the aim whose prediction lies nearest the
    fit (_arrival: how it arrives; torch axes interpolated), and that curve must be empty (_empty:
    for a groove, whose seam point lies in the air over its opening, no scan point on it; for an
    inside corner, whose seam point lies on the part's surfaces, none between the hole's edges)
    and in sight (hidden)."""
    params = extension.params
    step, slab = params.step_m, extension.surface.params.slab_m
    leads = _leads(last_point, aims)
    for distance in np.arange(params.max_skip_m + step, params.max_hole_m + step / 2, step):
        predictions = _predictions(aims, leads, distance)
        found = _fit_ahead(extension, predictions, last_axis)
        if found is None or not _measured(extension.joint, found[0]) or not _same_joint(extension, *found):
            continue
        fit = found[0]
        near = []
        for aim, lead, (predicted, travel) in zip(aims, leads, predictions):
            depth, sideways = offsets(fit.point_m, predicted, travel, last_axis)
            if sideways <= SIDEWAYS_SHARE * distance and depth <= max(0.5 * step, DEPTH_SHARE * distance):
                near.append((sideways, aim, lead, travel))
        if not near:
            continue
        _, (origin, direction, bend), lead, travel = min(near, key=lambda candidate: candidate[0])
        leaving = ahead(origin, direction, bend, lead)[1]  # the nearest aim's travel at the end
        run = [fit]
        while not _confirmed(run, slab):
            following = next_fit(extension, run[-1].point_m, run[-1].torch_axis, (travel, bend))
            if following is None:
                break
            run.append(following)
        confirmed = _confirmed(run, slab)
        if not confirmed and not _part_ends_after(extension, run[-1], travel, last_point, last_axis, leaving):
            return None
        return _bridge(extension, last_point, last_axis, leaving, run, _arrival(run, travel, bend))
    return None


def _confirmed(run: list[SectionFit], slab_m: float) -> bool:
    """Whether the fits beyond a hole confirm the seam there: HOLE_CONFIRM of them, the first and
    the last at least `slab_m` (a section's thickness) apart, so that they rest on different points."""
    return len(run) >= HOLE_CONFIRM and float(np.linalg.norm(run[-1].point_m - run[0].point_m)) >= slab_m


def _measured(joint: JointKind, fit: SectionFit) -> bool:
    """Whether a fit beyond a hole shows the joint itself: an inside corner's (joints.ON_SURFACE)
    with both faces seen. A corner with one face unseen may be where a surface ends in a shadow
    (past a pipe's silhouette), and across a hole nothing ties it to the seam (the extension
    follows such corners only near the curve of the seam's full fits)."""
    return joint not in ON_SURFACE or not fit.flags & PointFlag.ONE_FACE


def _leads(last_point, aims) -> list[float]:
    """How far (m) `last_point` lies ahead of each aim's origin along its direction (0 behind it)."""
    return [max(0.0, float((last_point - origin) @ direction)) for origin, direction, _ in aims]


def _predictions(aims, leads, distance: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """(predicted point, travel) of each aim `distance` on from the end (ends.ahead, its lead added)."""
    return [ahead(*aim, lead + distance) for aim, lead in zip(aims, leads)]


def _fit_ahead(extension: Extension, predictions, last_axis) -> tuple[SectionFit, np.ndarray] | None:
    """(fit, travel) of the first fit of the extension's joint in the sections at the aims'
    `predictions` (in turn), or None. A prediction near one tried before is not tried again: within
    section.RECENTRE_M for a joint whose fit does not assume it in the window's middle (a section
    there finds the same corner), within half a step for one that does (joints.recentred)."""
    same = RECENTRE_M if not recentred(extension.joint) else extension.params.step_m / 2
    tried = []
    for predicted, travel in predictions:
        if any(np.linalg.norm(predicted - other) <= same for other in tried):
            continue
        tried.append(predicted)
        fit = plain_fit(extension, predicted, travel, last_axis)
        if fit.kind == extension.joint:
            return fit, travel
    return None


def _same_joint(extension: Extension, fit: SectionFit, travel: np.ndarray) -> bool:
    """Whether the section of a fit beyond a hole (across `travel`, in the fit's frame), fitted for
    every joint, is the seam's joint or its kin (joints.one_joint): where a groove's model fits a
    square butt's gap seen obliquely (one wall, no flank), the joint there is the butt, and the
    groove does not go on across the hole to it."""
    found = extension.surface.fit(fit.point_m, travel, fit.torch_axis)
    return found.kind is not None and one_joint(found.kind, extension.joint)


def _arrival(run: list[SectionFit], travel: np.ndarray, bend: np.ndarray) -> np.ndarray:
    """The direction the seam arrives along at the first fit beyond a hole: along a straight aim
    (no `bend`), its `travel`, the tangent of ends.TANGENT_BASELINE_M of seam (two fits at a hole's
    edge, 2 mm apart, may lean 15 degrees, and the curve across has tangents as long as the hole);
    along a curve, from the first fit of `run` to its last (the aim's parabola turns off a ring's
    tangent by 5 degrees 35 mm out)."""
    if not bend.any() or len(run) < 2:
        return travel
    return unit(run[-1].point_m - run[0].point_m)


def _bridge(extension: Extension, last_point, last_axis, leaving, run: list[SectionFit], arrival):
    """The bridged points from `last_point` (leaving along `leaving`) to the first fit of `run`
    (arriving along `arrival`) on a cubic Hermite curve, then `run`; None when that curve is not
    empty (_empty) or something in front of it hides it (hidden)."""
    fit = run[0]
    line = hermite(last_point, leaving, fit.point_m, arrival, HOLE_RADIUS_M)
    surface = extension.surface
    if not _empty(line, extension.joint, surface, extension.params.max_skip_m) or hidden(line, surface):
        return None
    bridge = hermite(last_point, leaving, fit.point_m, arrival, extension.params.step_m)
    weights = np.linspace(0.0, 1.0, len(bridge) + 2)[1:-1, None]
    tilts = unit((1 - weights) * last_axis + weights * fit.torch_axis)
    geometry = JointGeometry(opening_m=2 * fit.half_opening_m)
    interpolated = int(PointFlag.INTERPOLATED)
    return [SectionFit(extension.joint, p, a, geometry, bridged=True, flags=interpolated)
            for p, a in zip(bridge, tilts)] + run  # fmt: skip


def _empty(line: np.ndarray, joint: JointKind, surface: FineSurface, max_edge_m: float) -> bool:
    """Whether the seam line across a hole (K, 3) is empty: no more than HOLE_STRAYS scan points
    within HOLE_RADIUS_M of it. A groove's seam point lies in the air over its opening: where a
    plate's surface crosses the line, the groove has ended. An inside corner's (joints.ON_SURFACE)
    lies on the part's surfaces, which go on from the hole's edges to the first fits (the sections
    there, cut by the hole, fail): the hole is the stretch from the line's first point with no scan
    point near to its last, at least HOLE_EDGE_M long and empty, the edges on either side at most
    `max_edge_m` long (the failed sections an extension steps over anyway); where the camera sees
    more than HOLE_STRAYS of the line's points CORNER_PAST_M or more beyond, the part has ended
    (with one camera, surface.view)."""
    near = surface.tree.query_ball_point(line, HOLE_RADIUS_M, return_length=True)
    if joint not in ON_SURFACE:
        return int(near.sum()) <= HOLE_STRAYS
    if not empty_between_edges(near, arc_lengths(line), max_edge_m):
        return False
    return surface.view is None or int(np.count_nonzero(surface.view.seen_past(line, CORNER_PAST_M))) <= HOLE_STRAYS


def empty_between_edges(counts: np.ndarray, arc: np.ndarray, max_edge_m: float) -> bool:
    """Whether a line's points, `counts` (K,) scan points seen at each and `arc` (K,) their arc
    along it from its start (m; the line runs on to arc[-1]), cross a hole: the stretch from the
    first point with none seen to the last is at least HOLE_EDGE_M long and holds no more than
    HOLE_STRAYS, and the hole's edges before and after it (ragged: the part's surfaces go on into
    it, where the sections, cut by the hole, fail) are each at most `max_edge_m` long."""
    free = np.flatnonzero(counts == 0)
    if len(free) == 0:
        return False
    first, last = free[0], free[-1]
    if arc[last] - arc[first] < HOLE_EDGE_M or int(counts[first : last + 1].sum()) > HOLE_STRAYS:
        return False
    return max(arc[first], arc[-1] - arc[last]) <= max_edge_m


def _part_ends_after(extension: Extension, fit, travel, last_point, last_axis, direction) -> bool:
    """Whether a groove's part ends within part_end_reach_m after `fit`, beyond a hole that began
    at `last_point`: the scan sees past the part there (bridge.sees_past_end) deeper than the
    groove's bottom, the deeper of its depths in the fit's section and in the section at
    `last_point` (a section at a hole's edge may hold only part of the groove; a fit that is not
    the groove, or not its whole depth, must not pass the groove going on for the part's end)."""
    if fit.kind != JointKind.V_GROOVE:
        return False
    before = extension.surface.fit(last_point, direction, last_axis, {JointKind.V_GROOVE})
    if before.kind != JointKind.V_GROOVE:
        return False
    surface = extension.surface
    bottoms = [groove_bottom(surface, f, t) for f, t in ((fit, travel), (before, direction))]
    if None in bottoms:
        return False
    return sees_past_end(surface, fit, travel, extension.params.part_end_reach_m, max(bottoms))


def hidden(curve: np.ndarray, surface: FineSurface) -> bool:
    """Whether the camera's lines of sight to more than HOLE_STRAYS of the `curve`'s points (K, 3)
    meet a surface OCCLUDER_MARGIN_M or more nearer (surface.view); False where no single camera
    is known (merged frames)."""
    if surface.view is None or len(curve) == 0:
        return False
    return int(np.count_nonzero(surface.view.nearer_than(curve, OCCLUDER_MARGIN_M) >= 0)) > HOLE_STRAYS


def hole_of(start: np.ndarray, fits: list[SectionFit]) -> Hole:
    """The Hole bridged from `start` by the bridged points at the head of `fits`."""
    line = np.array([start, *(f.point_m for f in fits if f.bridged), next(f.point_m for f in fits if not f.bridged)])
    middle = line[len(line) // 2]
    return Hole(tuple(round(float(v), 6) for v in middle), polyline_length(line))


def hermite(start, start_direction, end, end_direction, spacing_m: float) -> np.ndarray:
    """Points (K, 3) about `spacing_m` apart strictly between `start` and `end` on the cubic
    Hermite curve leaving `start` along `start_direction` and arriving along `end_direction`
    (tangent lengths = the chord)."""
    chord = np.linalg.norm(end - start)
    count = max(1, int(round(chord / spacing_m)))
    s = (np.arange(1, count) / count)[:, None]
    return ((2 * s**3 - 3 * s**2 + 1) * start + (s**3 - 2 * s**2 + s) * chord * start_direction
            + (3 * s**2 - 2 * s**3) * end + (s**3 - s**2) * chord * end_direction)  # fmt: skip
