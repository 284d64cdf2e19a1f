"""Extend: carry each open seam end section by section to the seam's real end.

From an end, the seam is predicted along its curve (ends.end_curve) and each step tries, in
turn, a short list of strategies; the first that finds the seam adds its fits, and the end is
re-aimed by them:

1. the next fit ahead (stepping over failed sections up to `max_skip_m`; a groove section in a
   dropout is bridged from the sections before: weldseam.pipeline.bridge), near the predicted
   curve or near the seam's straight line over its last stretch (the curve of a drifting end
   turns off the seam; seek.next_fit), sought along the curve and, at a shallow corner whose fits
   scatter across, along that line;
2. at an inside corner, the next corner whose one face is no longer seen, that face carried on
   from the sections where both were (carried.py);
3. a turn over a 90-degree edge (a groove over a block's edge, a seam up a wall: turn.py);
4. a tack weld over the seam just ahead, crossed on the seam line (tacks.py);
5. the part's end: where the scan sees past the part just ahead, the seam runs on along its
   straight line to where the joint ends (at most 6 mm), and stops there;
6. a hole in the scan over the whole seam, crossed and interpolated (holes.py).

When none finds the seam, the end stops. An extension stops where it comes within two steps of
the seam itself (it has gone round a loop; the ends then meet and the seam closes). Run on joined
seams only: extending every partial trace would walk the same seam once per piece.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from weldseam.config import ExtendConfig
from weldseam.geometry import arc_lengths, bend_corner, even_indices, polyline_length, unit
from weldseam.pipeline.bridge import GrooveTemplate, groove_template, part_ends_ahead
from weldseam.pipeline.carried import MIN_FITS, CornerTemplate, corner_template, full_corner
from weldseam.pipeline.ends import (
    CORNER_PAST_M, END_BASELINE_M, NOT_FULL, TANGENT_BASELINE_M, SeamLine, ahead, end_curve, end_fit, last_full,
    on_curve, seam_line,
)
from weldseam.pipeline.joints import ON_SURFACE, JointKind, one_joint
from weldseam.pipeline.parallel import map_shared
from weldseam.pipeline.section import FineSurface, PointFlag, SectionFit, section_frames
from weldseam.pipeline.holes import across_hole, hole_aims, hole_of
from weldseam.pipeline.seek import Extension, next_fit
from weldseam.pipeline.tacks import across_tack
from weldseam.pipeline.turn import turned_run
from weldseam.pipeline.trace import Hole, TracedSeam

# The groove template a bridged section assumes: the median of this many latest fits.
TEMPLATE_MEMORY = 6
# The joint is at a point on the seam's line where this many scan points lie on either side of it
# (across the seam: both faces, both plates) within RUN_OUT_RADIUS_M of it (plus a groove's
# half-opening), at or ahead of it along the line and within RUN_OUT_RADIUS_M of it along the torch
# axis (the table under a plate's end, 6-10 mm below, is not the joint; _run_out_step).
RUN_OUT_POINTS = 3
RUN_OUT_RADIUS_M = 0.003
# The seam is run on to the part's end only where that end lies within this of its last point:
# the sections that fail near an end span 2-6 mm of it (its slab and window reach past the end
# face); a seam that stops farther before the part's end (a groove filled up to a run-off, a web
# shorter than its flange) stops where it stops.
RUN_OUT_MAX_M = 0.006
# Where the line through a shallow corner's fitted end points and its curve's tangent differ by
# more than this, the next fit is also sought along the line (SeamEnd.aims).
LINE_AIM_DEG = 5.0
# A corner's faces are carried on from this many sections over the last TANGENT_BASELINE_M of
# arc up to its last fit with both faces seen; where those hold enough full fits for a template
# (carried.MIN_FITS) but fewer than this many, as many again over each stretch before it until they
# do (SeamEnd.corner). A pipe's face normals turn round its axis, and the fewer and the closer the
# fits, the more their noise tilts it: toward an independent scan's saddle's flank (a 26 mm
# branch) the last 32 mm held four full fits over 9 mm, whose normals turned too little to give
# the axis (the face's latest direction stood for it, 9 degrees off), and the carried wall, seen
# 2-7 degrees from edge-on at the branch's silhouette, then looked seen from behind.
CORNER_FITS = 8


@dataclass(frozen=True)
class Step:
    """One step of an extension: the fits it adds (bridged ones first across a hole), the hole it
    crossed, and after a turn over an edge, the travel on the new face and the first of the fits
    on it."""

    fits: list[SectionFit]
    hole: Hole | None = None
    turned_to: np.ndarray | None = None
    new_face_from: int = 0


STOP = Step([])  # a strategy's answer where the seam certainly ends here


def extend_seams(seams: list[TracedSeam], surface: FineSurface, params: ExtendConfig) -> list[TracedSeam]:
    """Every open seam extended at both ends (extend_seam), the ends of all seams shared with the
    worker process (parallel.map_shared). Each end of a seam longer than TANGENT_BASELINE_M (with
    at least TEMPLATE_MEMORY points) is extended on its own: its prediction and templates look no
    further back than that, so the other end's extension changes only where this one stops
    (where it comes back to the seam), and that is applied afterwards (_meeting_stop). The result
    is the same as extending one end after the other; a shorter seam is extended so."""
    jobs = []
    for k, seam in enumerate(seams):
        if seam.closed or len(seam.positions_m) < 2:
            continue
        others = _larger_pieces(seams, k)
        if len(seam.positions_m) >= TEMPLATE_MEMORY and polyline_length(seam.positions_m) > TANGENT_BASELINE_M:
            jobs += [(k, seam, True, params, others), (k, seam, False, params, others)]
        else:
            jobs.append((k, seam, None, params, others))
    done: dict[int, list] = {}
    for (k, *_), extension in zip(jobs, map_shared(_extension_job, (surface,), jobs)):
        done.setdefault(k, []).append(extension)
    result = list(seams)
    for k, ends in done.items():
        if len(ends) == 2:
            (start, start_stop), (end, end_stop) = ends
            end, end_stop = _meeting_stop(end, end_stop, start, params.step_m)
            result[k] = _extended(seams[k], start, start_stop, end, end_stop)
        else:
            result[k] = ends[0]
    return result


def _larger_pieces(seams: list[TracedSeam], k: int) -> np.ndarray:
    """(M, 3) where the k-th seam's extension stops, when it has fewer than TEMPLATE_MEMORY points
    (a piece of a few sections, its joint named by them alone): the points of every seam with more
    points whose joint is another (joints.one_joint). No points (0, 3) for a larger piece, nor from
    pieces of the same joint (its extension may reach further than the larger piece's own, as over
    a block's edge)."""
    own, size = seams[k].joint, len(seams[k].positions_m)
    if size >= TEMPLATE_MEMORY:
        return np.empty((0, 3))
    pieces = [seam.positions_m for seam in seams if len(seam.positions_m) > size and not one_joint(own, seam.joint)]
    return np.vstack(pieces) if pieces else np.empty((0, 3))


def extend_seam(
    seam: TracedSeam, surface: FineSurface, params: ExtendConfig, others: np.ndarray | None = None
) -> TracedSeam:
    """The seam with sections added beyond both open ends while they fit its joint near the
    predicted place (see the module), so the path reaches the seam's real ends (or `others`, the
    points of larger pieces: extend_end)."""
    if seam.closed or len(seam.positions_m) < 2:
        return seam
    extension = Extension(surface, seam.joint, params)
    start, start_stop = extend_end(extension, seam.positions_m[::-1], seam.torch_axes[::-1], seam.point_flags[::-1],
                                   seam.across_spread, others)
    before = _fits(start)[::-1]
    end, end_stop = extend_end(
        extension,
        np.array([f.point_m for f in before] + list(seam.positions_m)),
        np.array([f.torch_axis for f in before] + list(seam.torch_axes)),
        np.array([f.flags for f in before] + list(seam.point_flags), np.uint8),
        seam.across_spread,
        others,
    )
    return _extended(seam, start, start_stop, end, end_stop)


def _extension_job(surface: FineSurface, job) -> tuple[list[Step], Step | None] | TracedSeam:
    """(steps, stop) of one end of a seam (at_start True or False), or the whole seam extended
    (at_start None)."""
    _, seam, at_start, params, others = job
    if at_start is None:
        return extend_seam(seam, surface, params, others)
    order = slice(None, None, -1) if at_start else slice(None)
    return extend_end(Extension(surface, seam.joint, params), seam.positions_m[order], seam.torch_axes[order],
                      seam.point_flags[order], seam.across_spread, others)  # fmt: skip


def _fits(steps: list[Step]) -> list[SectionFit]:
    """The fits of all `steps`, in order."""
    return [fit for step in steps for fit in step.fits]


def _meeting_stop(end: list[Step], end_stop: Step | None, start: list[Step], step_m: float):
    """(steps, stop) of an end extended on its own, cut where extending one end after the other
    stops it: at its first step within two steps of the start's extension (a loop closing)."""
    if not start:
        return end, end_stop
    start_tree = cKDTree([f.point_m for f in _fits(start)])
    for k, step in enumerate(end):
        if start_tree.query([f.point_m for f in step.fits])[0].min() <= 2 * step_m:
            return end[:k], step
    return end, end_stop


def _extended(seam: TracedSeam, start: list[Step], start_stop, end: list[Step], end_stop) -> TracedSeam:
    """The seam with the fits of its start's steps (reversed) before it and its end's after it;
    its holes: its own, then those crossed by each end's steps and by the step that stopped it
    (it came back to the seam: the path closes across that hole)."""
    before, after = _fits(start)[::-1], _fits(end)
    holes = [step.hole for steps, stop in ((start, start_stop), (end, end_stop)) for step in [*steps, stop]
             if step is not None and step.hole is not None]  # fmt: skip
    return replace(
        seam,
        positions_m=np.array([f.point_m for f in before] + list(seam.positions_m) + [f.point_m for f in after]),
        torch_axes=np.array([f.torch_axis for f in before] + list(seam.torch_axes) + [f.torch_axis for f in after]),
        closed=False, holes=(*seam.holes, *holes),
        flags=np.array([f.flags for f in before] + list(seam.point_flags) + [f.flags for f in after], np.uint8),
    )


@dataclass
class SeamEnd:
    """An end being extended: its points, torch axes and which were bridged (travel order, the
    end last), where its current face begins (after a turn over an edge), the curve it is
    predicted along, the step and the longest skip over failed sections (m), the groove
    templates of its fits (a groove only), the curve at its last
    fit with both faces seen: (index, direction, bend, scatter), and the across_spread of its last fit
    (JointGeometry; at first the seam's)."""

    positions: list
    axes: list
    bridged: list
    direction: np.ndarray
    bend: np.ndarray
    step_m: float
    skip_m: float
    templates: list = field(default_factory=list)
    face_start: int = 0
    last_full: tuple = ()
    spread: float = 1.0
    corners: dict = field(default_factory=dict)

    @property
    def fitted(self) -> np.ndarray:
        """The fitted (not bridged) points on the current face."""
        return np.array(self.positions[self.face_start:])[~np.array(self.bridged[self.face_start:])]

    def admits(self, fit: SectionFit) -> bool:
        """Whether `fit` may carry the seam on: a fit of both faces anywhere; a corner with one face
        unseen near the curve of the last full fit (on_curve), or anywhere on a seam without one,
        unless its unseen face was placed from an outline (PointFlag.OUTLINE): that one needs the
        curve."""
        if not fit.flags & PointFlag.ONE_FACE:
            return True
        if not self.last_full:
            return not fit.flags & PointFlag.OUTLINE
        return self.on_curve(fit.point_m)

    def on_curve(self, point: np.ndarray) -> bool:
        """Whether `point` (3,), reached from the last point, lies near the curve at the last fit
        with both faces seen (last_full; ends.on_curve), sideways of the torch axis."""
        index, direction, bend, scatter = self.last_full
        arc = polyline_length(np.array(self.positions[index:])) + float(np.linalg.norm(point - self.positions[-1]))
        return on_curve(np.asarray(self.positions[index]), direction, bend, arc, point, self.axes[-1], scatter)

    def heading(self) -> tuple[np.ndarray, np.ndarray]:
        """(direction, bend) to predict the next step along: past bridged points along the curve
        from the last fitted one; right after a fit, straight (a fit per step re-aims it; the
        curvature of a noisy end is not worth following)."""
        since = _arc_since_fit(self.positions, self.bridged)
        return unit(self.direction + since * self.bend), (self.bend if since > 0 else np.zeros(3))

    def aims(self, line: SeamLine | None) -> list[tuple[np.ndarray, np.ndarray]]:
        """(direction, bend) pairs to seek the next fit along: the heading, and at a shallow corner
        (its last fit's across_spread over 1) where the straight `line` through this face's fitted
        points (ends.seam_line) points more than LINE_AIM_DEG from it, that line: such a corner's
        fits scatter a few mm across in a sensor's ripple, and the curve through the last of them
        follows that scatter. Right after a fit the heading runs straight on; where the end's curve
        leaves that line by more than half a step within skip_m (a ring of under ~70 mm), also the
        curve: past a stretch of failed sections the straight line misses a tight ring sideways,
        and its sections cut the seam askew."""
        heading = self.heading()
        aims = [heading]
        if self.spread > 1.0 and line is not None and line.direction @ heading[0] < np.cos(np.radians(LINE_AIM_DEG)):
            aims.append((line.direction, np.zeros(3)))
        if not heading[1].any() and 0.5 * self.skip_m**2 * np.linalg.norm(self.bend) > 0.5 * self.step_m:
            aims.append((self.direction, self.bend))
        return aims

    def template(self) -> GrooveTemplate | None:
        """Per side, and for the half-opening and the bottom, the median of the latest
        TEMPLATE_MEMORY templates that measured it (None for one measured in fewer than half of
        them); None when nothing qualifies."""
        recent = self.templates[-TEMPLATE_MEMORY:]
        values = []
        for name in ("left_m", "right_m", "half_opening_m", "bottom_m"):
            measured = [getattr(t, name) for t in recent if t is not None and getattr(t, name) is not None]
            values.append(float(np.median(measured)) if len(measured) >= max(2, len(recent) / 2) else None)
        return GrooveTemplate(*values) if any(v is not None for v in values) else None

    def corner(self, extension: Extension) -> CornerTemplate | None:
        """The rulings of a corner's faces (carried.corner_template) from CORNER_FITS sections over
        the last TANGENT_BASELINE_M of arc up to the last fit with both faces seen, and over each
        such stretch before it while they make a template but hold fewer than CORNER_FITS fits
        with both faces seen (carried.full_corner), back to the seam's start; fitted again once
        per such fit; None for another joint or without such a fit."""
        if extension.joint != JointKind.FILLET or not self.last_full:
            return None
        index = self.last_full[0]
        if index not in self.corners:
            positions, axes = np.array(self.positions[: index + 1]), np.array(self.axes[: index + 1])
            arc = arc_lengths(positions)
            fits, travels = [], []
            for end in arc[-1] - TANGENT_BASELINE_M * np.arange(int(arc[-1] // TANGENT_BASELINE_M) + 1):
                window = (arc >= end - TANGENT_BASELINE_M) & (arc <= end)
                if np.count_nonzero(window) < 2:
                    break
                travel, frame_axes, lateral = section_frames(positions[window], axes[window], closed=False)
                at = even_indices(len(travel), CORNER_FITS)
                fits = extension.surface.fit_many(positions[window][at], travel[at], frame_axes[at], lateral[at],
                                                  {JointKind.FILLET}) + fits  # fmt: skip
                travels.insert(0, travel[at])
                full = sum(map(full_corner, fits))
                if full < MIN_FITS or full >= CORNER_FITS:  # no template (corner_template), or enough
                    break
            self.corners[index] = corner_template(fits, np.concatenate([np.empty((0, 3)), *travels]))
        return self.corners[index]

    def add(self, step: Step, extension: Extension) -> None:
        """Take a step's fits, and re-aim along this face by its fitted sections (one step alone
        is ~10 degrees noisy; a bridged point leans on one edge, and aiming by it would turn a
        small offset into a drift)."""
        if step.turned_to is not None:
            self.direction, self.bend = step.turned_to, np.zeros(3)
            self.face_start = len(self.positions) + step.new_face_from
        self.positions += [f.point_m for f in step.fits]
        self.axes += [f.torch_axis for f in step.fits]
        self.bridged += [f.bridged for f in step.fits]
        self.spread = step.fits[-1].geometry.across_spread
        if extension.joint == JointKind.V_GROOVE:
            self.templates += [groove_template(extension.surface, f, self.direction)
                               for f in step.fits if not f.bridged]  # fmt: skip
        fitted = self.fitted
        scatter = 0.0
        if len(fitted) >= 3:
            self.direction, self.bend, scatter = end_fit(fitted)
        last = step.fits[-1]
        if not (last.bridged or last.flags & NOT_FULL):
            self.last_full = (len(self.positions) - 1, self.direction, self.bend, scatter)


def extend_end(
    extension: Extension, seam_positions, seam_axes, seam_flags=None, spread: float = 1.0,
    others: np.ndarray | None = None,
) -> tuple[list[Step], Step | None]:
    """The steps that extend a seam (points and axes in travel order, `spread` its across_spread)
    beyond its last point (see the module), and the step that stopped it where it came within two
    steps of the seam away from this end (None if it stopped otherwise). It also stops short of a
    step within two steps of `others` (M, 3; _larger_pieces): an extension carries its piece's
    joint on from its last fits, and where pieces overlap the longest is kept, so a piece of two
    or three sections carried over a traced piece of 70 took its place, its kind with it (a square
    butt named a V-groove or a bevel). A step of several fits (a hole crossed) keeps those short
    of the larger piece. Ahead, join takes the two on, or the larger one's own extension runs over
    this one."""
    positions = np.array(seam_positions)
    params = extension.params
    # The seam away from this end: an extension that reaches it has gone round a loop.
    arc = arc_lengths(positions)
    elsewhere = positions[arc < arc[-1] - 2 * END_BASELINE_M]
    elsewhere_tree = cKDTree(elsewhere) if len(elsewhere) else None
    ahead_tree = cKDTree(others) if others is not None and len(others) else None
    end = SeamEnd(list(seam_positions), list(seam_axes), [False] * len(positions), *end_curve(positions), params.step_m,
                  params.max_skip_m, templates=_end_templates(extension, positions, np.array(seam_axes)),
                  last_full=last_full(positions, seam_flags), spread=spread)  # fmt: skip
    steps: list[Step] = []
    for _ in range(int(params.max_extension_m / params.step_m)):
        step = next((found for strategy in STRATEGIES if (found := strategy(extension, end)) is not None), STOP)
        if step is STOP:
            break
        points = [f.point_m for f in step.fits]
        if elsewhere_tree is not None and elsewhere_tree.query(points)[0].min() <= 2 * params.step_m:
            return steps, step
        if ahead_tree is not None:
            near = np.flatnonzero(ahead_tree.query(points)[0] <= 2 * params.step_m)
            if len(near):
                if near[0]:  # a hole crossed up to the larger piece: its fits short of it
                    steps.append(replace(step, fits=step.fits[: near[0]]))
                break
        steps.append(step)
        end.add(step, extension)
    return steps, None


def _run_out_step(extension: Extension, end: SeamEnd, template: GrooveTemplate | None) -> Step | None:
    """At the part's end (_part_end_step), the seam run on to it: along the seam's straight line over
    its last stretch (seam_line of the fitted points), every step_m from the last point's foot on it
    up to the last point that still has the joint's two sides at or ahead of it (RUN_OUT_POINTS
    scan points each side across the seam within RUN_OUT_RADIUS_M, plus a groove's half-opening,
    not behind it along the line nor farther along the torch axis: a face or plate alone going on,
    or the table past the part's end, is no joint), bridged, with the last axis; None where the
    joint is there beyond RUN_OUT_MAX_M, or comes back within a step of it (a hole), or ends within
    a step. Sections within a few mm of a part's end fail (their slab and window reach past the end
    face, a tube's end, a Y's junction), and the path stopped 2-6 mm short of it. The end's curve
    is no guide there: fitted to the last fits, it leans with them (at a Y's junction, 2.8 mm off
    within 8 mm); the line over 32 mm does not. `template`: the end's groove template (SeamEnd.template)."""
    line = seam_line(end.fitted)
    if line is None:
        return None
    radius = RUN_OUT_RADIUS_M + (template.half_opening_m or 0.0 if template is not None else 0.0)
    step = extension.params.step_m
    foot = line.point + ((end.positions[-1] - line.point) @ line.direction) * line.direction
    ahead_of = foot + np.arange(step, RUN_OUT_MAX_M + 1.5 * step, step)[:, None] * line.direction
    lateral = unit(np.cross(line.direction, end.axes[-1]))
    axis = unit(np.cross(lateral, line.direction))
    held = []
    for predicted, members in zip(ahead_of, extension.surface.tree.query_ball_point(ahead_of, radius)):
        offsets = extension.surface.points[members] - predicted
        near = (offsets @ line.direction >= 0.0) & (np.abs(offsets @ axis) <= RUN_OUT_RADIUS_M)
        across = offsets[near] @ lateral
        held.append(min(np.count_nonzero(across < 0.0), np.count_nonzero(across > 0.0)) >= RUN_OUT_POINTS)
    held = np.array(held)
    if held.all() or not held[0] or held[np.argmin(held):].any():
        return None
    return Step([SectionFit(extension.joint, predicted, end.axes[-1], bridged=True, flags=int(PointFlag.BRIDGED))
                 for predicted in ahead_of[: np.argmin(held)]])  # fmt: skip


def _next_step(extension: Extension, end: SeamEnd) -> Step | None:
    """The next fit ahead along the predicted curve (seek.next_fit, bridged over dropouts)."""
    return _seek_step(extension, end, end.template())


def _carried_step(extension: Extension, end: SeamEnd) -> Step | None:
    """The next corner ahead with one face unseen, that face carried on from the fits with both
    faces seen (carried.py: SeamEnd.corner)."""
    corner = end.corner(extension)
    return None if corner is None else _seek_step(extension, end, corner)


def _seek_step(extension: Extension, end: SeamEnd, template: GrooveTemplate | CornerTemplate | None) -> Step | None:
    """The next fit ahead along each of the end's aims (seek.next_fit with `template`); a corner
    with one face unseen only near the curve of the last fit with both faces seen
    (SeamEnd.admits): past a pipe's silhouette the end of the plate seen is a shadow's edge,
    running off the pipe's foot along the line of sight."""
    line = seam_line(end.fitted)
    for heading in end.aims(line):
        fit = next_fit(extension, end.positions[-1], end.axes[-1], heading, template, line, end.spread)
        if fit is not None and end.admits(fit):
            return Step([fit])
    return None


def _turn_step(extension: Extension, end: SeamEnd) -> Step | None:
    """The seam on the face beyond a 90-degree edge (turn.turned_run), the corner put in where
    the two lines meet (the sections at the edge itself fail)."""
    direction, _ = end.heading()
    turned = turned_run(extension, end.positions[-1], end.axes[-1], direction)
    if turned is None:
        return None
    fits, travel = turned
    reach = extension.params.edge_search_m + 3 * extension.params.step_m
    corner = bend_corner(end.positions[-1], direction, fits[0].point_m, -travel, reach)
    if corner is not None:
        fits.insert(0, SectionFit(extension.joint, corner, unit(end.axes[-1] + fits[0].torch_axis)))
    return Step(fits, turned_to=travel, new_face_from=int(corner is not None))


def _tack_step(extension: Extension, end: SeamEnd) -> Step | None:
    """The seam carried across a tack weld standing over it just ahead (tacks.across_tack)."""
    direction, bend = end.heading()
    fits = across_tack(extension, end.positions[-1], end.axes[-1], direction, bend)
    return None if fits is None else Step(fits)


def _part_end_step(extension: Extension, end: SeamEnd) -> Step | None:
    """Where the scan sees past the part's end within part_end_reach_m ahead, the seam run on to
    that end (_run_out_step), then STOP: in a hole the camera sees nothing, past the part's end it
    sees what lies beyond (the table), and a seam on another part in line beyond that gap is
    another seam. A groove's (bridge.part_ends_ahead: deeper than its bottom, in its opening); an
    inside corner's (_corner_ends_ahead)."""
    template = end.template()
    direction, bend = end.heading()
    reach = extension.params.part_end_reach_m
    if template is not None and part_ends_ahead(extension.surface, end.positions[-1], direction, end.axes[-1],
                                                template, reach):  # fmt: skip
        return _run_out_step(extension, end, template) or STOP
    if extension.joint in ON_SURFACE and _corner_ends_ahead(extension, end.positions[-1], direction, bend):
        return _run_out_step(extension, end, template) or STOP
    return None


def _corner_ends_ahead(extension: Extension, last_point, direction, bend) -> bool:
    """Whether the camera sees past an inside corner's seam line (joints.ON_SURFACE) at half or more of the
    points one step apart along its predicted curve within part_end_reach_m ahead (ViewBuffer.
    seen_past, by CORNER_PAST_M); False without a single camera (no view)."""
    view = extension.surface.view
    if view is None:
        return False
    params = extension.params
    distances = np.arange(params.step_m, params.part_end_reach_m + params.step_m / 2, params.step_m)
    predicted = np.array([ahead(last_point, direction, bend, distance)[0] for distance in distances])
    return 2 * np.count_nonzero(view.seen_past(predicted, CORNER_PAST_M)) >= len(predicted)


def _hole_step(extension: Extension, end: SeamEnd) -> Step | None:
    """The seam carried across a hole in the scan over the whole seam (holes.across_hole), up to
    max_hole_m long, aimed along the end's curve and along the curve of the fits before the
    hole's edge, or where these disagree, along the tangent of each (holes.hole_aims)."""
    direction, _ = end.heading()
    aims = hole_aims(end.positions[-1], direction, end.bend, end.fitted, extension.params.max_hole_m)
    fits = across_hole(extension, end.positions[-1], end.axes[-1], aims)
    return None if fits is None else Step(fits, hole=hole_of(end.positions[-1], fits))


STRATEGIES = (_next_step, _carried_step, _turn_step, _tack_step, _part_end_step, _hole_step)


def _arc_since_fit(positions: list[np.ndarray], bridged: list[bool]) -> float:
    """Arc length (m) from the last fitted (not bridged) point to the last point."""
    fitted = np.flatnonzero(~np.array(bridged))
    first = fitted[-1] if len(fitted) else 0
    return float(polyline_length(np.array(positions[first:]))) if first < len(positions) - 1 else 0.0


def _end_templates(extension: Extension, positions, axes) -> list[GrooveTemplate | None]:
    """Groove templates at the last TEMPLATE_MEMORY seam points (none for other joints)."""
    if extension.joint != JointKind.V_GROOVE:
        return []
    tail = slice(max(0, len(positions) - TEMPLATE_MEMORY), len(positions))
    travel, tail_axes, lateral = section_frames(positions[tail], axes[tail], closed=False)
    fits = extension.surface.fit_many(positions[tail], travel, tail_axes, lateral, {JointKind.V_GROOVE})
    return [groove_template(extension.surface, fit, t) for fit, t in zip(fits, travel)
            if fit.kind == JointKind.V_GROOVE]  # fmt: skip
