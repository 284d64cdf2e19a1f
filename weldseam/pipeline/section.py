"""Cross-section analysis: classify the joint and locate the seam point and torch axis.

At each point c of a coarse seam line, with travel direction t and approximate torch axis a
(into the work), the fine points in a thin slab across the seam are projected onto the
section plane: u = lateral offset along l = t x a, w = height out of the work (-a). The
profile w(u) is fitted with two joint models:

- V-groove: a reference line through the plate surface on both sides (an upper-envelope
  robust fit), a depression below it at least `groove_min_depth_m` deep with surface on both
  sides, and a line fitted to each groove wall. Each groove edge is where its wall line meets
  the reference line (where a wall is hidden, the last surface point before the hole). The
  seam point is the midpoint of the two edges on the reference line; the torch axis is
  perpendicular to the reference line, fitted within `face_radius_m` beside the edges.
- Fillet / inside corner: two lines meeting at a concave corner (included angle 45..135
  degrees), each face at least `fillet_min_leg_m` long. The seam point is the corner; the
  torch axis is the bisector of the two faces, pointing into the corner.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from weldseam.config import SectionConfig
from weldseam.geometry import unit
from weldseam.pipeline.parallel import map_shared

V_GROOVE = "v_groove"
FILLET = "fillet"

# Bridging a dropout: how far a surface end may sit from where the template expects it, and
# how far past it a hole must reach.
BRIDGE_MARGIN_M = 0.0015
BRIDGE_HOLE_M = 0.004
# The least noise a plate surface is taken to have: depth quantised in 1 mm steps (RealSense
# and most structured-light cameras), seen square on, leaves most of a flat surface on one level
# and the next 1 mm below; the median deviation is then ~0 and that level would pass for a
# depression. 1 mm / sqrt(12) = 0.29 mm.
SURFACE_NOISE_FLOOR_M = 0.0003
# A groove edge put at the last surface point may lie this far beyond the mirror image of the
# other edge about the groove bottom (_groove_edges). With one wall hidden, the bottom (the
# median of the deepest points) sits up the visible wall, measured up to 1.2 mm, so the mirror
# falls up to ~2.5 mm short; the edges scatter by ~0.5 mm more.
HIDDEN_EDGE_SLACK_M = 0.004
# A section fit this far from its centre, or with its torch axis this far from the frame's, is
# fitted again in its own frame.
RECENTRE_M = 0.003
RECENTRE_COS = float(np.cos(np.radians(8.0)))
# Seeing past a part's end (sees_past_end): this many points (not a stray outlier or two) this far
# below the groove's bottom, beyond where depth noise puts a groove point (~0.5 mm sigma at 0.45 m,
# in 1 mm steps). A groove with less plate than that under its root is not seen past this way.
PAST_END_POINTS = 4
PAST_END_MARGIN_M = 0.002

@dataclass(frozen=True)
class SectionFit:
    """One cross-section's result in 3D: joint kind ("v_groove", "fillet" or "" for no fit),
    seam point (3,) in metres, unit torch axis (3,) into the work, for a groove half the width
    of its opening (m), and whether it was bridged over a dropout (fit_section)."""

    joint: str
    point_m: np.ndarray
    torch_axis: np.ndarray
    half_opening_m: float = 0.0
    bridged: bool = False


@dataclass(frozen=True)
class GrooveTemplate:
    """What the sections before know of a groove: where the plate surface ends beside it, as
    _surface_ends finds it (distances (m) from the seam point to the last surface point on the
    left (-lateral) and right sides; None: not seen), half the width of its opening (m) and its
    depth below the surface (m, groove_bottom)."""

    left_m: float | None
    right_m: float | None
    half_opening_m: float | None = None
    bottom_m: float | None = None

    @property
    def edges_seen(self) -> bool:
        return self.left_m is not None or self.right_m is not None

    def expected(self, side: int) -> float | None:
        """The distance on `side` (-1 left, +1 right); a side not seen mirrors the other."""
        own, other = (self.left_m, self.right_m) if side < 0 else (self.right_m, self.left_m)
        return own if own is not None else other


@dataclass(frozen=True)
class _ProfileFit:
    joint: str
    u: float
    w: float
    axis_u: float
    axis_w: float
    half_opening: float = 0.0


@dataclass(frozen=True)
class SectionParams:
    """Cross-section parameters (see SectionConfig); `min_points`: a slab holding fewer points
    is taken twice as thick (sparse, grazing data)."""

    half_width_m: float
    slab_m: float
    face_radius_m: float
    groove_min_depth_m: float
    fillet_min_leg_m: float
    min_points: int


def section_params(config: SectionConfig, voxel_m: float) -> SectionParams:
    """The section parameters of a SectionConfig. `min_points` is what a fully sampled flat
    section holds at the fine voxel: (2 half_width / voxel) x (slab / voxel)."""
    return SectionParams(
        half_width_m=config.half_width_m, slab_m=config.slab_m, face_radius_m=config.face_radius_m,
        groove_min_depth_m=config.groove_min_depth_m, fillet_min_leg_m=config.fillet_min_leg_m,
        min_points=round(2 * config.half_width_m * config.slab_m / voxel_m**2),
    )


def section_frames(centres: np.ndarray, axes: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Travel t (K, 3), torch axis a made perpendicular to t, and lateral l = t x a."""
    if closed:
        travel = np.roll(centres, -1, axis=0) - np.roll(centres, 1, axis=0)
    else:
        travel = np.gradient(centres, axis=0) if len(centres) > 1 else np.zeros_like(centres)
    travel = unit(travel)
    axes = unit(axes - np.sum(axes * travel, axis=1, keepdims=True) * travel)
    return travel, axes, np.cross(travel, axes)


def analyse_sections(
    points: np.ndarray,
    tree,
    centres: np.ndarray,
    travel: np.ndarray,
    axes: np.ndarray,
    lateral: np.ndarray,
    params: SectionParams,
    joint: str | None = None,
) -> list[SectionFit]:
    """Fit every cross-section; `tree` is a cKDTree over the fine `points` (N, 3). `joint`
    (V_GROOVE or FILLET): the only joint sought (fit_profile); None: either.

    A groove fit far from its centre, or with a torch axis far from the frame's (a coarse line
    that runs along one groove wall), is fitted again in the frame it found: centred on its seam
    point, across the same travel, with its torch axis. The groove then sits in the middle of
    the window with its surface level, as the fit assumes. (A fillet's corner, where two
    fitted lines meet, does not depend on where the window sits.)"""
    fits = _fit_sections(points, tree, centres, travel, axes, lateral, params, joint)
    moved = [
        k for k, fit in enumerate(fits)
        if fit.joint == V_GROOVE
        and (np.linalg.norm(fit.point_m - centres[k]) > RECENTRE_M or fit.torch_axis @ axes[k] < RECENTRE_COS)
    ]
    if moved:
        again_axes, again_lateral = zip(*(_frame(travel[k], fits[k].torch_axis) for k in moved))
        again = _fit_sections(
            points, tree, np.array([fits[k].point_m for k in moved]), travel[moved], np.array(again_axes),
            np.array(again_lateral), params, joint,
        )
        for k, fit in zip(moved, again):
            if fit.joint == fits[k].joint:
                fits[k] = fit
    return fits


def _fit_sections(points, tree, centres, travel, axes, lateral, params: SectionParams, joint) -> list[SectionFit]:
    """One fit per centre, in the frames given (half of them on the worker process, if one is
    running: parallel.worker_process)."""
    frames = zip(centres, travel, axes, lateral)
    return map_shared(_fit_one, (points, tree), [(*frame, params, joint) for frame in frames])


def _fit_one(points, tree, item) -> SectionFit:
    """The section fit of one (centre, travel, axis, lateral, params, joint)."""
    centre, t, a, lat, params, joint = item
    u, w, _ = _profile_at(points, tree, centre, t, a, lat, params)
    return _to_3d(_fit_profile_with(params, u, w, joint), centre, a, lat)


def _fit_profile_with(params: SectionParams, u: np.ndarray, w: np.ndarray, joint: str | None) -> _ProfileFit | None:
    """fit_profile with the section parameters."""
    return fit_profile(
        u, w, face_radius_m=params.face_radius_m, groove_min_depth_m=params.groove_min_depth_m,
        fillet_min_leg_m=params.fillet_min_leg_m, joint=joint,
    )


def fit_section(
    points: np.ndarray, tree, centre: np.ndarray, travel: np.ndarray, axis: np.ndarray, params: SectionParams,
    template: GrooveTemplate | None = None, joint: str | None = None,
) -> SectionFit:
    """The one section at `centre` (3,) across `travel`, `axis` made perpendicular to it;
    `joint`: the only joint sought (fit_profile).

    Where no groove fits and the sections before describe the groove (`template`), the section
    is fitted again within half the groove's opening + face_radius / 2 of the centre (where a
    plate edge crosses the section obliquely, the table beyond it sits beside the groove and
    spoils the surface line); failing that, where the surface ends beside the groove are known,
    it is bridged over a sensor dropout (see bridge_groove) from the same profile, or, where the
    scan sees past the part's end within the section window's reach ahead (part_ends_ahead), over
    an end that crosses the groove obliquely (up to 70 degrees from square such an end cuts one
    side tan(70) x half-opening before the seam line: 22 mm for an 8 mm half-opening)."""
    axis, lateral = _frame(travel, axis)
    u, w, along = _profile_at(points, tree, centre, travel, axis, lateral, params)
    profile = _fit_profile_with(params, u, w, joint)
    if template is None or (profile is not None and profile.joint == V_GROOVE):
        return _to_3d(profile, centre, axis, lateral)
    if template.half_opening_m is not None:
        near = np.abs(u) <= template.half_opening_m + params.face_radius_m / 2
        profile = _fit_profile_with(params, u[near], w[near], joint)
        if profile is not None and profile.joint == V_GROOVE:
            return _to_3d(profile, centre, axis, lateral)
    if not template.edges_seen:
        return _to_3d(None, centre, axis, lateral)
    bridge = dict(face_radius_m=params.face_radius_m, groove_min_depth_m=params.groove_min_depth_m)
    bridged = bridge_groove(u, w, along, template, **bridge)
    if bridged is None and part_ends_ahead(points, tree, centre, travel, axis, template, params.half_width_m, params):
        bridged = bridge_groove(u, w, along, template, **bridge, part_ends=True)
    return replace(_to_3d(bridged, centre, axis, lateral), bridged=True)


def part_ends_ahead(
    points, tree, centre, travel, axis, template: GrooveTemplate, reach_m: float, params: SectionParams
) -> bool:
    """Whether the scan sees past the part's end (sees_past_end) within `reach_m` ahead of
    `centre`, on the groove the template describes (its half-opening and bottom; False when
    either is unknown)."""
    if template.bottom_m is None or template.half_opening_m is None:
        return False
    ahead = SectionFit(V_GROOVE, centre, axis, template.half_opening_m)
    return sees_past_end(points, tree, ahead, travel, reach_m, template.bottom_m, params)


def groove_template(points: np.ndarray, tree, fit: SectionFit, travel: np.ndarray, params: SectionParams):
    """The GrooveTemplate of a fitted groove section: its half-opening, and where the plate
    surface ends beside it, measured as a bridged section measures it."""
    u, w = _fit_profile_points(points, tree, fit, travel, params)
    found = _surface_ends(u, w, fit.half_opening_m, fit.half_opening_m, params.groove_min_depth_m)
    ends = found[1] if found is not None else {}
    return GrooveTemplate(-ends[-1] if -1 in ends else None, ends[1] if 1 in ends else None, fit.half_opening_m,
                          _bottom(u, w, fit.half_opening_m))  # fmt: skip


def groove_bottom(points: np.ndarray, tree, fit: SectionFit, travel: np.ndarray, params: SectionParams):
    """How deep a groove fit's groove is (m below its surface line), from its section (_bottom)."""
    return _bottom(*_fit_profile_points(points, tree, fit, travel, params), fit.half_opening_m)


def _fit_profile_points(points, tree, fit: SectionFit, travel: np.ndarray, params: SectionParams):
    """(u, w) of the section through a fit's seam point, across `travel`, in the fit's own frame."""
    u, w, _ = _profile_at(points, tree, fit.point_m, travel, *_frame(travel, fit.torch_axis), params)
    return u, w


def _bottom(u: np.ndarray, w: np.ndarray, half_opening_m: float) -> float | None:
    """The upper decile of the depths -w of a groove section's points in its opening
    (|u| <= half-opening, u and w from its seam point); None with fewer than PAST_END_POINTS
    points there (a fillet has no opening)."""
    depth = -w[np.abs(u) <= half_opening_m]
    return _upper_decile(depth) if len(depth) >= PAST_END_POINTS else None


def sees_past_end(
    points: np.ndarray, tree, fit: SectionFit, travel: np.ndarray, reach_m: float, bottom_m: float,
    params: SectionParams,
) -> bool:
    """Whether the scan sees past the part's end within `reach_m` ahead of a groove fit: at least
    PAST_END_POINTS points ahead of its section (0 < along <= reach_m) and within its opening
    (|u| <= half-opening) lie deeper than the groove's bottom `bottom_m` + PAST_END_MARGIN_M,
    spread across at least half the opening's width. Through the opening of a groove that goes
    on, the camera sees the groove (and through a root gap, what lies behind it along the seam
    line only); past the plate's end it sees what lies behind it (the table, the floor); in a
    hole it sees nothing."""
    axis, lateral = _frame(travel, fit.torch_axis)
    centre = fit.point_m + reach_m / 2 * travel
    offsets = points.take(tree.query_ball_point(centre, reach_m / 2 + params.half_width_m), axis=0) - fit.point_m
    along, u, depth = offsets @ travel, offsets @ lateral, offsets @ axis
    ahead = (along > 0) & (along <= reach_m) & (np.abs(u) <= fit.half_opening_m)
    beyond = ahead & (depth > bottom_m + PAST_END_MARGIN_M)
    return np.count_nonzero(beyond) >= PAST_END_POINTS and np.ptp(u[beyond]) >= fit.half_opening_m


def _frame(travel: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The torch axis made perpendicular to `travel`, and the lateral direction travel x axis."""
    axis = unit(axis - (axis @ travel) * travel)
    return axis, np.cross(travel, axis)


def _profile_at(points, tree, centre, travel, axis, lateral, params: SectionParams):
    """_profile of the one section at `centre`."""
    members = tree.query_ball_point(centre, params.half_width_m, return_sorted=False)
    # take converts the list of indices at a third of the cost of indexing with it.
    return _profile(points.take(members, axis=0) - centre, travel, axis, lateral, params)


def _profile(offsets, t, a, lat, params: SectionParams):
    """(u, w, along) of the points (offsets from the centre, (N, 3)) in the slab across t:
    u along lat, w along -a, along t. A slab with fewer than `min_points` is taken twice as
    thick when the thicker slab's points lie evenly on both sides of the section plane (not so
    just past a part's end)."""
    along, u, w = offsets @ t, offsets @ lat, -(offsets @ a)
    inside = (np.abs(u) <= params.half_width_m) & (np.abs(w) <= params.half_width_m)
    keep = inside & (np.abs(along) <= params.slab_m / 2)
    # Grazing or sparse data: a slab twice as thick (sagitta < 0.1 mm at r 50 mm).
    if np.count_nonzero(keep) < params.min_points:
        thick = inside & (np.abs(along) <= params.slab_m)
        if _balanced(along[thick]):
            keep = thick
    return u[keep], w[keep], along[keep]


def _balanced(along: np.ndarray) -> bool:
    """Whether 35-65 % of the points lie ahead of the section plane."""
    return 0.35 * len(along) <= np.count_nonzero(along > 0) <= 0.65 * len(along)


def _to_3d(profile: _ProfileFit | None, centre, a, lat) -> SectionFit:
    if profile is None:
        return SectionFit("", centre, a)
    point = centre + profile.u * lat - profile.w * a
    axis = unit(profile.axis_u * lat - profile.axis_w * a)
    return SectionFit(profile.joint, point, axis, profile.half_opening)


def fit_profile(
    u: np.ndarray, w: np.ndarray, *, face_radius_m: float, groove_min_depth_m: float, fillet_min_leg_m: float,
    joint: str | None = None,
) -> _ProfileFit | None:
    """The joint in one 2D profile (u lateral, w height out of the work), or None: a V-groove,
    else a fillet; only the one `joint` (V_GROOVE or FILLET) where the caller seeks that one
    (the extension of a seam: a fit of the other kind would be rejected anyway)."""
    if len(u) < 12:
        return None
    order = np.argsort(u, kind="stable")
    u, w = u[order], w[order]
    groove = _fit_groove(u, w, face_radius_m, groove_min_depth_m) if joint != FILLET else None
    return groove or (_fit_fillet(u, w, fillet_min_leg_m) if joint != V_GROOVE else None)


def _line(u: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """Least-squares line w = intercept + slope * u, in closed form (called thousands of
    times per scan on a few hundred points, where lstsq's overhead dominates)."""
    count = len(u)
    mean_u, mean_w = float(np.add.reduce(u)) / count, float(np.add.reduce(w)) / count
    du = u - mean_u
    spread = float(du @ du)
    slope = float(du @ (w - mean_w)) / spread if spread > 0 else 0.0
    return float(mean_w - slope * mean_u), slope


def _median(values: np.ndarray) -> float:
    """Upper median by partition (np.median's overhead dominates on a few hundred values)."""
    middle = len(values) // 2
    ordered = values.copy()
    ordered.partition(middle)
    return float(ordered[middle])


def _upper_decile(values: np.ndarray) -> float:
    """The 90th percentile, interpolated as np.percentile does, by partition (np.percentile's
    overhead dominates on a few dozen values)."""
    position = 0.9 * (len(values) - 1)
    low = int(position)
    high = min(low + 1, len(values) - 1)
    ordered = values.copy()
    ordered.partition((low, high))
    return float(ordered[low] + (position - low) * (ordered[high] - ordered[low]))


def _noise(residuals: np.ndarray) -> float:
    """Robust standard deviation: 1.4826 x the median absolute deviation (+ 10 um floor)."""
    return 1.4826 * _median(np.abs(residuals - _median(residuals))) + 1e-5


def _fit_groove(u: np.ndarray, w: np.ndarray, face_radius_m: float, min_depth_m: float) -> _ProfileFit | None:
    half_width = max(abs(u[0]), abs(u[-1]))
    # Upper envelope: start from the outer halves, then repeatedly ignore points below the line.
    on_surface = np.abs(u) > half_width / 2
    if np.count_nonzero(on_surface) < 6:
        return None
    for _ in range(6):
        intercept, slope = _line(u[on_surface], w[on_surface])
        residual = w - (intercept + slope * u)
        sigma = max(_noise(residual[on_surface]), SURFACE_NOISE_FLOOR_M)
        depth_limit = max(3 * sigma, 0.4 * min_depth_m)
        updated = (residual > -depth_limit) & (residual < 4 * sigma + depth_limit)
        if np.count_nonzero(updated) < 6 or np.array_equal(updated, on_surface):
            break
        on_surface = updated
    depth = -residual
    deep = np.flatnonzero(depth > depth_limit)
    if len(deep) < 4:
        return None
    # The depression: the largest run of deep points with gaps under 4 mm between them (the
    # first of the largest).
    groove = deep
    breaks = np.flatnonzero(np.diff(u[deep]) > 0.004) + 1
    if len(breaks):
        bounds = np.concatenate(([0], breaks, [len(deep)]))
        longest = int(np.argmax(np.diff(bounds)))
        groove = deep[bounds[longest] : bounds[longest + 1]]
    u_start, u_end = u[groove[0]], u[groove[-1]]
    left_surface = on_surface & (u < u_start)
    right_surface = on_surface & (u > u_end)
    if np.count_nonzero(left_surface) < 4 or np.count_nonzero(right_surface) < 4:
        return None
    if _upper_decile(depth[groove]) < min_depth_m:
        return None
    edges = _groove_edges(u, depth, groove, u[left_surface].max(), u[right_surface].min(), slope)
    if edges is None:
        return None
    u_left, u_right = edges
    # The surface beside the seam, within face_radius of each edge, sets the torch axis.
    beside = on_surface & (
        ((u >= u_left - face_radius_m) & (u <= u_left)) | ((u >= u_right) & (u <= u_right + face_radius_m))
    )
    if np.count_nonzero(beside) >= 6:
        intercept, slope = _line(u[beside], w[beside])
    centre_u = (u_left + u_right) / 2
    norm = np.hypot(1.0, slope)
    return _ProfileFit(V_GROOVE, centre_u, intercept + slope * centre_u, slope / norm, -1.0 / norm,
                       (u_right - u_left) / 2)  # fmt: skip


def bridge_groove(
    u: np.ndarray, w: np.ndarray, along: np.ndarray, template: GrooveTemplate, *, face_radius_m: float,
    groove_min_depth_m: float, part_ends: bool = False,
) -> _ProfileFit | None:
    """The groove in a profile where a dropout hides too much of it to fit (fit_profile found
    nothing), from where the plate surface ends on either side (_surface_ends), or None.
    `along` (m) places each point along the seam: the surface must lie evenly on both sides of
    the section plane (a section just past the part's end is not bridged).

    The sections before give the template: the surface ends `template.left_m` left and
    `template.right_m` right of the seam point. With both ends seen (each within 1.5 mm of
    where the template puts it, and agreeing on the seam point within 3 mm), the seam is the
    mean of the two the template implies. With one seen (and measured in the template: a side
    never measured cannot place the seam), the other side must be a hole (_hole_beyond; a
    plate's outer or oblique end is not a hole), or, where the caller found the part ending just
    ahead (`part_ends`), the plate on that side must have ended while the groove's root is still
    under the seam (_plate_ended); the seam is then where the seen end puts it.
    """
    left, right = template.expected(-1), template.expected(1)
    found = _surface_ends(u, w, left, right, groove_min_depth_m)
    if found is None or not _balanced(along[found[0]]):
        return None
    surface, ends = found
    measured = {-1: template.left_m, 1: template.right_m}
    implied = {side: end - side * measured[side] for side, end in ends.items() if measured[side] is not None}
    if len(implied) == 2:
        if abs(implied[1] - implied[-1]) > 2 * BRIDGE_MARGIN_M:
            return None
        centre_u = (implied[1] + implied[-1]) / 2
    elif len(implied) == 1 and len(ends) == 1:
        ((seen, centre_u),) = implied.items()
        hidden = -seen * (u - centre_u)
        expected = template.expected(-seen)
        if not (_hole_beyond(hidden, surface, expected)
                or (part_ends and _plate_ended(u, w, hidden, surface, expected, centre_u, template))):
            return None
    else:
        return None
    half_opening = (left + right) / 2
    beside = surface & (np.abs(u - centre_u) <= half_opening + face_radius_m)
    intercept, slope = _line(u[beside], w[beside]) if np.count_nonzero(beside) >= 6 else _line(u[surface], w[surface])
    norm = np.hypot(1.0, slope)
    return _ProfileFit(V_GROOVE, float(centre_u), intercept + slope * centre_u, slope / norm, -1.0 / norm, half_opening)


def _hole_beyond(hidden, surface, expected_m: float) -> bool:
    """Whether a groove's hidden side is a hole: no points from BRIDGE_MARGIN_M inside to
    BRIDGE_HOLE_M outside its expected surface end, and surface again beyond."""
    if np.any((hidden > expected_m - BRIDGE_MARGIN_M) & (hidden < expected_m + BRIDGE_HOLE_M)):
        return False
    return np.count_nonzero(surface & (hidden >= expected_m + BRIDGE_HOLE_M)) >= 4


def _plate_ended(u, w, hidden, surface, expected_m: float, centre_u: float, template: GrooveTemplate) -> bool:
    """Whether the plate on a groove's hidden side has ended (an end crossing the groove
    obliquely) while the groove's root still lies under the seam: no surface point on that side
    beyond BRIDGE_MARGIN_M inside its expected end, and at least 4 points within BRIDGE_MARGIN_M
    of the seam line up to PAST_END_MARGIN_M above the groove's bottom, none counted below it
    (past a square end, the table under a thin root face lies just below the root and must not
    pass for it)."""
    if template.bottom_m is None or np.any(surface & (hidden > expected_m - BRIDGE_MARGIN_M)):
        return False
    intercept, slope = _line(u[surface], w[surface])
    depth = intercept + slope * u - w
    root = (np.abs(u - centre_u) <= BRIDGE_MARGIN_M) & (depth >= template.bottom_m - PAST_END_MARGIN_M) & (
        depth <= template.bottom_m)
    return np.count_nonzero(root) >= 4


def _surface_ends(u, w, left_m: float, right_m: float, groove_min_depth_m: float):
    """(surface mask, {side: u}) for a groove expected to span -left_m .. right_m: the plate
    surface is a line fitted to the points beyond that span, its points within
    max(3 sigma, 0.4 groove_min_depth) of it; the end on a side (-1 left, +1 right) is the
    innermost surface point there, kept when it lies within BRIDGE_MARGIN_M of the expected
    end with at least 4 surface points beyond it. None when the surface runs across the middle
    half of the span (the groove has ended; its walls near the edges pass for surface within
    the tolerance) or there is too little surface to fit."""
    outer = (u < -left_m - BRIDGE_MARGIN_M) | (u > right_m + BRIDGE_MARGIN_M)
    near_surface = outer & (np.abs(w) < groove_min_depth_m)
    if np.count_nonzero(near_surface) < 6:
        return None
    intercept, slope = _line(u[near_surface], w[near_surface])
    residual = w - (intercept + slope * u)
    tolerance = max(3 * _noise(residual[near_surface]), 0.4 * groove_min_depth_m)
    surface = np.abs(residual) < tolerance
    if np.any(surface & (u > -left_m / 2) & (u < right_m / 2)):
        return None
    ends = {}
    for side, expected in ((-1, left_m), (1, right_m)):
        beyond = side * u
        on_side = surface & (beyond > expected - BRIDGE_MARGIN_M)
        if np.count_nonzero(on_side) >= 4:
            end = beyond[on_side].min()
            if abs(end - expected) <= BRIDGE_MARGIN_M:
                ends[side] = float(side * end)
    return surface, ends


def _groove_edges(
    u, depth, groove, left_surface_end, right_surface_end, surface_slope: float
) -> tuple[float, float] | None:
    """Where each groove wall meets the surface (depth 0), or None when neither wall is
    seen: a bevelled wall facing the camera is always visible, so a depression with two
    hidden (vertical) walls is a hole or a slot, not a V-groove.

    Each wall is the points between the last surface point and the groove bottom (its middle
    15-80 %); a robust line depth = c + m u through them is solved for depth 0.
    A wall too short to fit on its own takes the other wall's slope mirrored (bevels are
    symmetric) and fits only its offset. A hidden wall (no points: it faces away from the
    camera) ends at the last surface point, which the camera sees right up to the edge.
    Such an edge (or one whose wall line meets the surface out of range) lying more than
    HIDDEN_EDGE_SLACK_M beyond the mirror image of the other edge about the groove bottom is
    not seen: a dropout or a shadow goes on past it onto the plate, and there is no fit. The
    bottom is mirrored about its foot on the surface line w = c + s u (`surface_slope` s;
    `depth` is measured vertically from that line): u - depth s / (1 + s^2).
    The last surface point is not used for a visible wall: its shallowest points pass for
    surface, so that point lies ~1 mm inside the edge, and the bias differs side to side.
    """
    deepest = _upper_decile(depth[groove])
    bottom = _median(u[groove][depth[groove] >= 0.8 * deepest])
    # Wall points are chosen by position across the groove, never by depth: choosing by the
    # fitted variable would bias the line where the noise differs between the walls.
    walls = []
    for surface_end in (left_surface_end, right_surface_end):
        near, far = surface_end + 0.15 * (bottom - surface_end), surface_end + 0.8 * (bottom - surface_end)
        low, high = sorted((near, far))
        walls.append(np.flatnonzero((u >= low) & (u <= high)))
    slopes = [_wall_slope(u[wall], depth[wall], side) for wall, side in zip(walls, (-1, 1))]
    if slopes == [None, None]:
        return None
    edges, at_surface_end = [], []
    for side, wall, slope, other, surface_end in zip(
        (-1, 1), walls, slopes, slopes[::-1], (left_surface_end, right_surface_end)
    ):
        if slope is None and other is not None and len(wall) >= 2:
            slope = -other
        edge = None
        if slope is not None:
            edge = -_median(depth[wall] - slope * u[wall]) / slope
            # Between 3 mm outside the last surface point and the middle of the wall.
            low, high = sorted((surface_end + side * 0.003, float(np.add.reduce(u[wall])) / len(wall)))
            edge = edge if low <= edge <= high else None
        at_surface_end.append(edge is None)
        edges.append(float(surface_end if edge is None else edge))
    foot = bottom - deepest * surface_slope / (1 + surface_slope**2)
    for side, edge, other, unseen in zip((-1, 1), edges, edges[::-1], at_surface_end):
        if unseen and side * (edge - (2 * foot - other)) > HIDDEN_EDGE_SLACK_M:
            return None
    return edges[0], edges[1]


def _wall_slope(u: np.ndarray, depth: np.ndarray, side: int) -> float | None:
    """Slope of a robust line through one wall's points (`u` ascending), or None when there are
    too few or the line is not steep toward the middle (at least 11 degrees)."""
    if len(u) < 4 or u[-1] - u[0] < 0.0006:
        return None
    intercept, slope = _line(u, depth)
    residual = depth - (intercept + slope * u)
    inliers = np.abs(residual) <= 2.5 * _noise(residual)
    if np.count_nonzero(inliers) >= 4:
        intercept, slope = _line(u[inliers], depth[inliers])
    return slope if slope * side < -0.2 else None


def _fit_fillet(u: np.ndarray, w: np.ndarray, min_leg_m: float) -> _ProfileFit | None:
    """Two lines, left and right of a break; the break minimising the total squared error."""
    n = len(u)
    splits = np.arange(5, n - 4)
    if len(splits) == 0:
        return None
    # Running sums of 1, u, w, u^2, uw, w^2 (one column each; a cumulative sum runs in order).
    sums = np.cumsum(np.column_stack([np.ones(n), u, w, u * u, u * w, w * w]), axis=0)
    left = sums[splits - 1]
    right = sums[-1] - left
    error = _segment_error(*left.T) + _segment_error(*right.T)
    split = int(splits[np.argmin(error)])
    fits = []
    for part in (slice(0, split), slice(split, n)):
        pu, pw = u[part], w[part]
        intercept, slope = _line(pu, pw)
        residual = pw - (intercept + slope * pu)
        inliers = np.abs(residual) <= max(3 * _noise(residual), 0.0005)
        if inliers.mean() < 0.8 or np.count_nonzero(inliers) < 5:
            return None
        fits.append((*_line(pu[inliers], pw[inliers]), pu[inliers]))
    (a1, b1, u1), (a2, b2, u2) = fits
    if not (b1 < 0 < b2):  # concave: both faces rise away from the corner
        return None
    corner_u = (a2 - a1) / (b1 - b2)
    corner_w = a1 + b1 * corner_u
    to_left = unit(np.array([-1.0, -b1]))
    to_right = unit(np.array([1.0, b2]))
    included = np.degrees(np.arccos(np.clip(to_left @ to_right, -1.0, 1.0)))
    # Each face must really be there: its points spread at least a leg along the face, and
    # are dense enough to fill it (a few noisy points beside a hole make a steep "face"
    # whose u-extent times its slope looks long).
    leg_left = _face_extent(u1, a1 + b1 * u1, corner_u, corner_w, to_left)
    leg_right = _face_extent(u2, a2 + b2 * u2, corner_u, corner_w, to_right)
    if not (45.0 <= included <= 135.0) or min(leg_left, leg_right) < min_leg_m:
        return None
    axis = -unit(to_left + to_right)
    return _ProfileFit(FILLET, float(corner_u), float(corner_w), float(axis[0]), float(axis[1]))


def _face_extent(u, w, corner_u, corner_w, direction, max_spacing_m: float = 0.002) -> float:
    """How far a face reaches from the corner along `direction`, counting only a stretch
    its points fill with gaps of at most `max_spacing_m`."""
    along = np.sort((u - corner_u) * direction[0] + (w - corner_w) * direction[1])
    gaps = np.flatnonzero(np.diff(along) > max_spacing_m)
    start = along[gaps[-1] + 1] if len(gaps) else along[0]
    return float(along[-1] - max(start, 0.0)) if along[-1] > 0 else 0.0


def _segment_error(count, su, sw, suu, suw, sww):
    """Residual sum of squares of the least-squares line through a segment, from its sums."""
    var_u = suu - su * su / count
    cov = suw - su * sw / count
    var_w = sww - sw * sw / count
    return var_w - np.divide(cov * cov, var_u, out=np.zeros_like(cov), where=var_u > 1e-12)
