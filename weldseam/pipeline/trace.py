"""Tracing: turn a coarse ordered chain into seam points via cross-sections.

A chain's sections are fitted; the seam's joint is the kind most sections agree on, and
a chain where fewer than `min_valid_fraction` of the sections fit that joint is not a seam
(plate outer edges, table edges, steps, noise). Runs of failed sections longer than
`max_gap_m` split the seam. `extend_seam` carries a seam's open ends section by section to
the seam's real ends (never its end caps).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from weldseam.geometry import arc_lengths, bend_corner, polyline_length, unit
from weldseam.pipeline.order import Chain
from weldseam.pipeline.parallel import map_shared
from weldseam.pipeline.section import (
    V_GROOVE,
    GrooveTemplate,
    SectionFit,
    SectionParams,
    analyse_sections,
    fit_section,
    groove_bottom,
    groove_template,
    part_ends_ahead,
    section_frames,
    sees_past_end,
)

PROBE_SECTIONS = 3
END_BASELINE_M = 0.012
# A turn over an edge counts once the seam goes on this far along the new face.
TURN_CONFIRM_M = 0.024
TANGENT_BASELINE_M = 0.032
# The tightest bend an extension predicts (the curvature of a noisy end is clamped to it).
MIN_BEND_RADIUS_M = 0.03
# The groove template a bridged section assumes: the median of this many latest fits.
TEMPLATE_MEMORY = 6
# Crossing a hole in the scan: the seam must fit this many times in a row beyond it (or up to the
# part's end), and the seam line across it hold no more than HOLE_STRAYS points within
# HOLE_RADIUS_M (_across_hole).
HOLE_CONFIRM = 2
HOLE_RADIUS_M = 0.0015
HOLE_STRAYS = 2
# A hole's edge cuts the sections beside it short (one groove wall seen, the other not), so the
# fits within this much arc of it may lean sideways: a hole is aimed across from the fits before.
HOLE_EDGE_M = 0.006


@dataclass(frozen=True)
class Hole:
    """A stretch of seam interpolated across a hole in the scan: its middle (3,) and length (m)."""

    middle_m: tuple[float, float, float]
    length_m: float


@dataclass(frozen=True)
class TracedSeam:
    """Seam points (K, 3) and torch axes (K, 3) in travel order, the holes in the scan the
    seam was interpolated across (extend_seam), and, for a groove, the median half-width of
    its opening (m) as traced."""

    positions_m: np.ndarray
    torch_axes: np.ndarray
    closed: bool
    joint: str
    confidence: float
    holes: tuple[Hole, ...] = ()
    half_opening_m: float = 0.0


def probe_chains(
    chains: list[Chain], approx_axes: list[np.ndarray], points, tree, section_params: SectionParams
) -> list[dict[int, SectionFit]]:
    """For each chain, the fits of PROBE_SECTIONS evenly spaced sections along it, by chain point
    index: a chain where none fits a joint is not a seam (most candidates are plate or table
    edges, rejected this way without fitting every section), and trace_chain reuses them. All
    chains' probes are fitted in one batch (half on the worker process)."""
    probes = []
    for chain, axes in zip(chains, approx_axes):
        travel, frame_axes, lateral = section_frames(chain.points, axes, chain.closed)
        at = np.unique(np.linspace(0, len(chain.points) - 1, PROBE_SECTIONS).round().astype(int))
        probes.append((at, (chain.points[at], travel[at], frame_axes[at], lateral[at])))
    if not probes:
        return []
    frames = (np.concatenate(part) for part in zip(*(frame for _, frame in probes)))
    fits = iter(analyse_sections(points, tree, *frames, section_params))
    return [{int(k): next(fits) for k in at} for at, _ in probes]


def trace_chain(
    chain: Chain,
    approx_axes: np.ndarray,
    probe_fits: dict[int, SectionFit],
    points: np.ndarray,
    tree,
    *,
    step_m: float,
    max_gap_m: float,
    min_valid_fraction: float,
    section_params: SectionParams,
) -> list[TracedSeam]:
    """Seams found along one chain (none if the chain is not a seam): a section at every
    chain point (probe_chains first rejects most chains that are not). The chain's probes are
    sections at some of its points in the same frames, fitted as these are: they are not
    fitted again."""
    travel, axes, lateral = section_frames(chain.points, approx_axes, chain.closed)
    rest = np.array([k for k in range(len(chain.points)) if k not in probe_fits], dtype=int)
    fitted = iter(analyse_sections(points, tree, chain.points[rest], travel[rest], axes[rest], lateral[rest],
                                   section_params))  # fmt: skip
    fits = [probe_fits[k] if k in probe_fits else next(fitted) for k in range(len(chain.points))]
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
                half_opening_m=float(np.median([fit.half_opening_m for fit in run_fits])),
            )
        )
    return seams


def inside_traced(points: np.ndarray, seams: list[TracedSeam], beside_m: float) -> bool:
    """Whether each of `points` (K, 3) lies inside the opening of one of `seams` or within
    `beside_m` of it: within its half-opening + beside_m of one of its seam points. The crease
    band of a groove often breaks into lines along its edges, and each traces (re-centred) to
    the seam itself: once the seam is traced, tracing such a line again adds nothing."""
    covered = np.zeros(len(points), bool)
    for seam in seams:
        reach = seam.half_opening_m + beside_m
        covered |= cKDTree(seam.positions_m).query(points, distance_upper_bound=reach)[0] <= reach
    return bool(covered.all())


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


def end_direction(points: np.ndarray, at_start: bool) -> np.ndarray:
    """Outward unit direction at one end: the principal direction of the points within
    ~12 mm of arc from the end, pointing out (the last few points alone are too noisy)."""
    ordered = points if at_start else points[::-1]
    arc = arc_lengths(ordered)
    k = max(1, min(int(np.searchsorted(arc, END_BASELINE_M)), len(ordered) - 1))
    chord = ordered[0] - ordered[k]
    window = ordered[: k + 1] - ordered[: k + 1].mean(axis=0)
    direction = np.linalg.svd(window, full_matrices=False)[2][0] if k >= 2 else chord
    return unit(direction if direction @ chord >= 0 else -direction)


def end_curve(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangent t and curvature vector k (1/m, perpendicular to t) at the last of `points`
    (in travel order), from a quadratic p(s) = a + b s + c s^2 fitted over the last
    TANGENT_BASELINE_M of arc: t = -b/|b|, k = 2c without its component along t, at most
    1/MIN_BEND_RADIUS_M. The seam ahead is predicted as p + d t + d^2 k / 2 (_ahead). A chord
    or principal direction over that stretch of a curve of radius R leans back by baseline / 2R
    (0.1 rad over 12 mm at R = 60 mm), which is 0.2 mm sideways per 2 mm step."""
    ordered = points[::-1]
    arc = arc_lengths(ordered)
    window = ordered[arc <= TANGENT_BASELINE_M]
    if len(window) < 5:
        return end_direction(points, at_start=False), np.zeros(3)
    s = arc[: len(window)]
    design = np.column_stack([np.ones_like(s), s, s * s])
    coefficients = np.linalg.lstsq(design, window, rcond=None)[0]
    tangent = unit(-coefficients[1])
    bend = 2 * coefficients[2]
    bend -= (bend @ tangent) * tangent
    size = np.linalg.norm(bend)
    return tangent, bend * min(1.0, 1.0 / (MIN_BEND_RADIUS_M * size)) if size > 0 else bend


def _ahead(last_point, direction, bend, distance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The predicted seam point `distance_m` on along the curve (end_curve) and its travel."""
    return last_point + distance_m * direction + 0.5 * distance_m**2 * bend, unit(direction + distance_m * bend)


def extend_seams(
    seams: list[TracedSeam], points, tree, *, step_m: float, max_gap_m: float, max_extension_m: float,
    max_hole_m: float, section_params: SectionParams,
) -> list[TracedSeam]:
    """extend_seam of every seam, the ends of all seams shared with the worker process
    (parallel.map_shared). Each end of a seam longer than TANGENT_BASELINE_M (with at least
    TEMPLATE_MEMORY points) is extended on its own: its prediction and templates look no
    further back than that, so the other end's extension changes only where this one stops
    (where it comes back to the seam), and that is applied afterwards (_meeting_stop). The
    result is the same as extending one end after the other; a shorter seam is extended so."""
    search = dict(step_m=step_m, max_gap_m=max_gap_m, max_extension_m=max_extension_m, max_hole_m=max_hole_m,
                  section_params=section_params)  # fmt: skip
    jobs = []
    for k, seam in enumerate(seams):
        if seam.closed or len(seam.positions_m) < 2:
            continue
        if len(seam.positions_m) >= TEMPLATE_MEMORY and polyline_length(seam.positions_m) > TANGENT_BASELINE_M:
            jobs += [(k, seam, True, search), (k, seam, False, search)]
        else:
            jobs.append((k, seam, None, search))
    done: dict[int, list] = {}
    for (k, *_), extension in zip(jobs, map_shared(_extension_job, (points, tree), jobs)):
        done.setdefault(k, []).append(extension)
    result = list(seams)
    for k, ends in done.items():
        if len(ends) == 2:
            (start, start_stop), (end, end_stop) = ends
            end, end_stop = _meeting_stop(end, end_stop, start, step_m)
            result[k] = _extended(seams[k], start, start_stop, end, end_stop)
        else:
            result[k] = ends[0]
    return result


def extend_seam(
    seam: TracedSeam, points, tree, *, step_m: float, max_gap_m: float, max_extension_m: float,
    max_hole_m: float, section_params: SectionParams,
) -> TracedSeam:
    """The seam with sections added beyond both open ends while they fit its joint near
    the predicted place, so the path reaches the seam's real ends.

    A section that fails (a hole, a spatter blob) is stepped over; the extension stops after
    `max_gap_m` without a fit. A fit counts when it lies within max(1.5 steps, 15 % of the
    distance from the last fit) of the straight-line prediction sideways (the fit is a
    verified joint profile and the better estimate: near an end the prediction drifts by
    1-3 mm; the bound follows curves of radius down to ~40 mm across the largest gap), and
    within max(half a step, 20 % of the distance) along the torch axis (the surface does not
    jump, a section that straddles the part's end face does; but an end tangent fitted to end
    points that drift in depth leans into the work, 1-2 mm over a 12 mm gap). Where the
    straight line finds nothing, the seam may turn 90 degrees over an edge (a groove running
    over a block's edge, or up a wall): the turned prediction is tried within max_gap_m of the
    end, and a run of fits there at least TURN_CONFIRM_M long continues the seam on the new
    face. Where neither finds the seam, it may cross a hole in the scan up to `max_hole_m` long
    (_across_hole); the hole is filled with interpolated (bridged) points. No hole is sought
    where the scan sees past the part's end within max_gap_m ahead (part_ends_ahead): in a hole
    the camera sees nothing, past the part's end it sees what lies beyond (the table), and a
    seam on another part in line beyond that gap is another seam. An extension stops
    where it comes within two steps of the seam itself (it has gone round a loop; the ends then
    meet and the seam closes). Run on joined seams only: extending every partial trace would
    walk the same seam once per piece.
    """
    if seam.closed or len(seam.positions_m) < 2:
        return seam
    search = dict(points=points, tree=tree, joint=seam.joint, step_m=step_m, max_gap_m=max_gap_m,
                  max_extension_m=max_extension_m, max_hole_m=max_hole_m, section_params=section_params)  # fmt: skip
    start, start_stop = _extend_end(seam.positions_m[::-1], seam.torch_axes[::-1], **search)
    before = _fits(start)[::-1]
    end, end_stop = _extend_end(
        np.array([f.point_m for f in before] + list(seam.positions_m)),
        np.array([f.torch_axis for f in before] + list(seam.torch_axes)), **search,
    )
    return _extended(seam, start, start_stop, end, end_stop)


@dataclass(frozen=True)
class _Step:
    """One step of an extension: the fits it adds (bridged ones first across a hole) and the
    hole it crossed, if any."""

    fits: list[SectionFit]
    hole: Hole | None = None


def _fits(steps: list[_Step]) -> list[SectionFit]:
    """The fits of all `steps`, in order."""
    return [fit for step in steps for fit in step.fits]


def _extension_job(points, tree, job) -> tuple[list[_Step], _Step | None] | TracedSeam:
    """(steps, stop) of one end of a seam (at_start True or False), or the whole seam extended
    (at_start None)."""
    _, seam, at_start, search = job
    if at_start is None:
        return extend_seam(seam, points, tree, **search)
    order = slice(None, None, -1) if at_start else slice(None)
    return _extend_end(seam.positions_m[order], seam.torch_axes[order], points=points, tree=tree, joint=seam.joint,
                       **search)  # fmt: skip


def _meeting_stop(end: list[_Step], end_stop: _Step | None, start: list[_Step], step_m: float):
    """(steps, stop) of an end extended on its own, cut where extending one end after the other
    stops it: at its first step within two steps of the start's extension (a loop closing)."""
    if not start:
        return end, end_stop
    start_tree = cKDTree([f.point_m for f in _fits(start)])
    for k, step in enumerate(end):
        if start_tree.query([f.point_m for f in step.fits])[0].min() <= 2 * step_m:
            return end[:k], step
    return end, end_stop


def _extended(seam: TracedSeam, start: list[_Step], start_stop, end: list[_Step], end_stop) -> TracedSeam:
    """The seam with the fits of its start's steps (reversed) before it and its end's after it;
    its holes: its own, then those crossed by each end's steps and by the step that stopped it
    (it came back to the seam: the path closes across that hole)."""
    before, after = _fits(start)[::-1], _fits(end)
    holes = [step.hole for steps, stop in ((start, start_stop), (end, end_stop)) for step in [*steps, stop]
             if step is not None and step.hole is not None]  # fmt: skip
    return TracedSeam(
        np.array([f.point_m for f in before] + list(seam.positions_m) + [f.point_m for f in after]),
        np.array([f.torch_axis for f in before] + list(seam.torch_axes) + [f.torch_axis for f in after]),
        False, seam.joint, seam.confidence, (*seam.holes, *holes),
    )


def _extend_end(
    seam_positions, seam_axes, *, points, tree, joint, step_m, max_gap_m, max_extension_m, max_hole_m,
    section_params,
) -> tuple[list[_Step], _Step | None]:
    """The steps that extend a seam (points and axes in travel order) beyond its last point
    (see extend_seam), and the step that stopped it where it came within two steps of the
    seam away from this end (None if it stopped otherwise)."""
    positions, axes = list(seam_positions), list(seam_axes)
    search = dict(points=points, tree=tree, joint=joint, step_m=step_m, max_gap_m=max_gap_m,
                  section_params=section_params)  # fmt: skip
    # The seam away from this end: an extension that reaches it has gone round a loop.
    arc = arc_lengths(np.array(positions))
    elsewhere = np.array(positions)[arc < arc[-1] - 2 * END_BASELINE_M]
    elsewhere_tree = cKDTree(elsewhere) if len(elsewhere) else None
    face_start = 0  # where the seam's current face begins (after a turn over an edge)
    direction, bend = end_curve(np.array(positions))
    bridged = [False] * len(positions)
    fitted = np.array(positions)
    templates = _end_templates(np.array(positions), np.array(axes), points, tree, joint, section_params)
    steps: list[_Step] = []
    for _ in range(int(max_extension_m / step_m)):
        # Past bridged points the seam is predicted along the curve from the last fitted one;
        # right after a fit, straight (a fit per 2 mm step re-aims it; the curvature of a
        # noisy end is not worth following).
        since = _arc_since_fit(positions, bridged)
        heading, ahead_bend = unit(direction + since * bend), (bend if since > 0 else np.zeros(3))
        template = _median_template(templates)
        fit = _next_fit(positions[-1], axes[-1], heading, ahead_bend, template=template, **search)
        fits, hole = [fit], None
        if fit is None:
            turned = _turned_run(positions[-1], axes[-1], heading, **search)
            if turned is not None:
                fits, travel = turned
                corner = bend_corner(positions[-1], heading, fits[0].point_m, -travel, max_gap_m + 3 * step_m)
                if corner is not None:  # the sections at the edge itself fail: put the real corner in
                    fits.insert(0, SectionFit(joint, corner, unit(axes[-1] + fits[0].torch_axis)))
                direction, bend = travel, np.zeros(3)
                face_start = len(positions) + (corner is not None)
            elif template is not None and part_ends_ahead(points, tree, positions[-1], heading, axes[-1], template,
                                                          max_gap_m, section_params):  # fmt: skip
                break  # the scan sees past the part's end: no hole to cross
            else:
                aims = [(positions[-1], heading, bend), _hole_aim(fitted)]
                fits = _across_hole(positions[-1], axes[-1], [aim for aim in aims if aim is not None],
                                    max_hole_m=max_hole_m, **search)  # fmt: skip
                if fits is None:
                    break
                hole = _hole(positions[-1], fits)
        step = _Step(fits, hole)
        if elsewhere_tree is not None and elsewhere_tree.query([f.point_m for f in fits])[0].min() <= 2 * step_m:
            return steps, step
        steps.append(step)
        positions += [f.point_m for f in fits]
        axes += [f.torch_axis for f in fits]
        bridged += [f.bridged for f in fits]
        if joint == V_GROOVE:
            templates += [groove_template(points, tree, f, direction, section_params)
                          for f in fits if not f.bridged]  # fmt: skip
        # Re-aim along this face (one 2 mm step alone is ~10 degrees noisy), by fitted sections
        # only: a bridged point leans on one edge, and aiming by it would turn a small offset into a drift.
        fitted = np.array(positions[face_start:])[~np.array(bridged[face_start:])]
        if len(fitted) >= 3:
            direction, bend = end_curve(fitted)
    return steps, None


def _hole(start: np.ndarray, fits: list[SectionFit]) -> Hole:
    """The Hole bridged from `start` by the bridged points at the head of `fits`."""
    line = np.array([start, *(f.point_m for f in fits if f.bridged), next(f.point_m for f in fits if not f.bridged)])
    middle = line[len(line) // 2]
    return Hole(tuple(round(float(v), 6) for v in middle), polyline_length(line))


def _arc_since_fit(positions: list[np.ndarray], bridged: list[bool]) -> float:
    """Arc length (m) from the last fitted (not bridged) point to the last point."""
    fitted = np.flatnonzero(~np.array(bridged))
    first = fitted[-1] if len(fitted) else 0
    return float(polyline_length(np.array(positions[first:]))) if first < len(positions) - 1 else 0.0


def _section_at(points, tree, predicted, travel, axis, section_params, joint, template=None):
    """(fit, depth, sideways) of the section at `predicted` seeking `joint` (bridged with a
    template where it does not fit); depth and sideways are the fit's offsets (m) from the
    prediction along and across the axis."""
    fit = fit_section(points, tree, predicted, travel, axis, section_params, template, joint)
    return fit, *_offsets(fit.point_m, predicted, travel, axis)


def _offsets(point, predicted, travel, axis) -> tuple[float, float]:
    """(depth, sideways): the offsets (m) of `point` from `predicted` along the torch `axis`
    (made perpendicular to `travel`) and across it."""
    axis = unit(axis - (axis @ travel) * travel)
    offset = point - predicted
    depth = abs(offset @ axis)
    return depth, np.linalg.norm(offset - (offset @ axis) * axis)


def _end_templates(positions, axes, points, tree, joint, section_params) -> list[GrooveTemplate | None]:
    """Groove templates at the last TEMPLATE_MEMORY seam points (none for a fillet)."""
    if joint != V_GROOVE:
        return []
    tail = slice(max(0, len(positions) - TEMPLATE_MEMORY), len(positions))
    travel, tail_axes, lateral = section_frames(positions[tail], axes[tail], closed=False)
    fits = analyse_sections(points, tree, positions[tail], travel, tail_axes, lateral, section_params, V_GROOVE)
    return [groove_template(points, tree, fit, t, section_params)
            for fit, t in zip(fits, travel) if fit.joint == V_GROOVE]  # fmt: skip


def _median_template(templates: list[GrooveTemplate | None]) -> GrooveTemplate | None:
    """Per side, and for the half-opening and the bottom, the median of the latest
    TEMPLATE_MEMORY templates that measured it (None for one measured in fewer than half of
    them); None when nothing qualifies."""
    recent = templates[-TEMPLATE_MEMORY:]
    values = []
    for name in ("left_m", "right_m", "half_opening_m", "bottom_m"):
        measured = [getattr(t, name) for t in recent if t is not None and getattr(t, name) is not None]
        values.append(float(np.median(measured)) if len(measured) >= max(2, len(recent) / 2) else None)
    return GrooveTemplate(*values) if any(v is not None for v in values) else None


def _next_fit(
    last_point, last_axis, direction, bend, *, points, tree, joint, step_m, max_gap_m, section_params, template=None
):
    """The next fit along the predicted curve from the end (_ahead; stepping over failed sections),
    or None. Where a section fails and the groove's template is known, it is bridged (a dropout
    over part of the groove)."""
    distance = step_m
    while distance <= max_gap_m:
        predicted, travel = _ahead(last_point, direction, bend, distance)
        fit, depth, sideways = _section_at(points, tree, predicted, travel, last_axis, section_params, joint, template)
        near = sideways <= max(1.5 * step_m, 0.15 * distance) and depth <= max(0.5 * step_m, 0.2 * distance)
        if fit.joint == joint and near:
            return fit
        distance += step_m
    return None


def _hole_aim(fitted: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(origin, direction, bend) of a curve to seek the seam along across a hole after the
    `fitted` seam points (travel order): from the last of them more than HOLE_EDGE_M of arc
    before the end, along the seam's curve there (end_curve of the fits up to it); None when
    fewer than three fits lie before the edge."""
    arc = arc_lengths(fitted[::-1])
    before = fitted[: len(fitted) - int(np.searchsorted(arc, HOLE_EDGE_M, side="right"))]
    return (before[-1], *end_curve(before)) if len(before) >= 3 else None


def _across_hole(
    last_point, last_axis, aims, *, points, tree, joint, step_m, max_gap_m, max_hole_m, section_params
) -> list[SectionFit] | None:
    """Bridged points across a hole in the scan after `last_point` followed by the first
    HOLE_CONFIRM fits beyond it, or None.

    Sections are tried from max_gap_m to max_hole_m ahead of the end along the curve of the first
    of `aims` (origin, direction, bend: _ahead from the origin, the end's distance from it
    added). The first section that fits the joint within 25 % of its distance sideways and 5 % in
    depth of any aim's prediction (the fits at a hole's edge may lean, and the aim from before
    them finds the seam where the end's own tangent misses it: _hole_aim) must be followed by
    HOLE_CONFIRM - 1 more fits in a row, or by the part's end (_part_ends_after): a hole can reach
    to within a section or two of the plate's end, and the scan then sees past the plate right
    after the fits (a stray fit inside a longer hole has nothing after it). The hole is bridged by
    a cubic Hermite curve between the two ends and their travel directions on that aim (torch axes
    interpolated), and that curve must be empty: no more than HOLE_STRAYS scan points within
    HOLE_RADIUS_M of it. For a groove the seam point is the centre of the opening, in the air over
    the groove; where a plate's surface crosses the line, the groove has ended, and one ahead is
    another seam."""
    leads = [max(0.0, float((last_point - origin) @ direction)) for origin, direction, _ in aims]
    for distance in np.arange(max_gap_m + step_m, max_hole_m + step_m / 2, step_m):
        predicted, travel = _ahead(*aims[0], leads[0] + distance)
        fit = fit_section(points, tree, predicted, travel, last_axis, section_params, joint=joint)
        if fit.joint != joint:
            continue
        for (origin, direction, bend), lead in zip(aims, leads):
            predicted, travel = _ahead(origin, direction, bend, lead + distance)
            depth, sideways = _offsets(fit.point_m, predicted, travel, last_axis)
            if sideways <= 0.25 * distance and depth <= max(0.5 * step_m, 0.05 * distance):
                break
        else:
            continue
        leaving = _ahead(origin, direction, bend, lead)[1]  # the aim's travel at the end
        run = [fit]
        while len(run) < HOLE_CONFIRM:
            following = _next_fit(run[-1].point_m, run[-1].torch_axis, travel, bend, points=points, tree=tree,
                                  joint=joint, step_m=step_m, max_gap_m=max_gap_m,
                                  section_params=section_params)  # fmt: skip
            if following is None:
                break
            run.append(following)
        if len(run) < HOLE_CONFIRM and not _part_ends_after(
            run[-1], travel, last_point, last_axis, leaving, points=points, tree=tree, reach_m=max_gap_m,
            section_params=section_params,
        ):
            return None
        arrival = unit(run[-1].point_m - run[0].point_m) if len(run) > 1 else travel
        line = _hermite(last_point, leaving, fit.point_m, arrival, HOLE_RADIUS_M)
        if tree.query_ball_point(line, HOLE_RADIUS_M, return_length=True).sum() > HOLE_STRAYS:
            return None
        bridge = _hermite(last_point, leaving, fit.point_m, arrival, step_m)
        weights = np.linspace(0.0, 1.0, len(bridge) + 2)[1:-1, None]
        tilts = unit((1 - weights) * last_axis + weights * fit.torch_axis)
        return [SectionFit(joint, p, a, fit.half_opening_m, bridged=True) for p, a in zip(bridge, tilts)] + run
    return None


def _part_ends_after(fit, travel, last_point, last_axis, direction, *, points, tree, reach_m, section_params) -> bool:
    """Whether a groove's part ends within `reach_m` after `fit`, beyond a hole that began at
    `last_point`: the scan sees past the part there (sees_past_end) deeper than the groove's
    bottom, the deeper of its depths in the fit's section and in the section at `last_point`
    (a section at a hole's edge may hold only part of the groove; a fit that is not the groove,
    or not its whole depth, must not pass the groove going on for the part's end)."""
    if fit.joint != V_GROOVE:
        return False
    before = fit_section(points, tree, last_point, direction, last_axis, section_params, joint=V_GROOVE)
    if before.joint != V_GROOVE:
        return False
    bottoms = [groove_bottom(points, tree, f, t, section_params) for f, t in ((fit, travel), (before, direction))]
    if None in bottoms:
        return False
    return sees_past_end(points, tree, fit, travel, reach_m, max(bottoms), section_params)


def _hermite(start, start_direction, end, end_direction, spacing_m: float) -> np.ndarray:
    """Points (K, 3) about `spacing_m` apart strictly between `start` and `end` on the cubic
    Hermite curve leaving `start` along `start_direction` and arriving along `end_direction`
    (tangent lengths = the chord)."""
    chord = np.linalg.norm(end - start)
    count = max(1, int(round(chord / spacing_m)))
    s = (np.arange(1, count) / count)[:, None]
    return ((2 * s**3 - 3 * s**2 + 1) * start + (s**3 - 2 * s**2 + s) * chord * start_direction
            + (3 * s**2 - 2 * s**3) * end + (s**3 - s**2) * chord * end_direction)  # fmt: skip


def _turned_run(last_point, last_axis, direction, *, points, tree, joint, step_m, max_gap_m, section_params):
    """(fits, new direction) of the seam on the face beyond a 90-degree edge, or None.

    Over a convex edge (off a block's top, down its side) the travel turns into the old torch axis
    and the torch axis into minus the old travel; at a concave corner (from the floor up a wall)
    the travel turns against the old torch axis and the torch axis into the old travel. The edge
    is sought up to max_gap_m ahead in two-step strides; the first fit, three steps past it, must
    sit on the turned line within 1.5 steps sideways and one step in depth (half the stride), and
    the seam must go on along the new face for TURN_CONFIRM_M: a plate's end face (under 12 mm
    tall) shows the groove's walls receding like a groove for a few sections, a block's side
    carries the seam on.
    """
    axis = unit(last_axis - (last_axis @ direction) * direction)
    for travel, new_axis in ((axis, -direction), (-axis, direction)):
        for edge in np.arange(0.0, max_gap_m + step_m, 2 * step_m):
            corner = last_point + edge * direction
            fit, depth, sideways = _section_at(points, tree, corner + 3 * step_m * travel, travel, new_axis,
                                               section_params, joint)  # fmt: skip
            if fit.joint != joint or sideways > 1.5 * step_m or depth > step_m:
                continue
            run = [fit]
            while np.linalg.norm(run[-1].point_m - run[0].point_m) < TURN_CONFIRM_M:
                following = _next_fit(run[-1].point_m, run[-1].torch_axis, travel, np.zeros(3), points=points,
                                      tree=tree, joint=joint, step_m=step_m, max_gap_m=max_gap_m,
                                      section_params=section_params)  # fmt: skip
                if following is None:
                    break
                run.append(following)
            else:
                return run, travel
    return None


def seam_length(seam: TracedSeam) -> float:
    """Arc length (m), including the closing segment of a loop."""
    return polyline_length(seam.positions_m, seam.closed)


