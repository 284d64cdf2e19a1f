"""Grooves the sections cannot fit alone: dropouts over part of a groove, and plate ends.

Where a sensor dropout hides too much of a groove for the V-groove model, the sections before
it say where the plate surface ends beside the groove (a GrooveTemplate), and the seam is placed
from the edge(s) still seen. The same measurements tell where the scan sees past a part's end:
through the opening of a groove that goes on, the camera sees the groove; past the plate's end,
what lies behind it (the table); in a hole, nothing.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

from weldseam.config import JointsConfig
from weldseam.pipeline.joints import JointGeometry, JointKind, ProfileFit
from weldseam.pipeline.joints.robust import line, noise, upper_decile
from weldseam.pipeline.section import FineSurface, Profile, SectionFit, balanced, section_frame

GROOVE = JointKind.V_GROOVE
# How far a surface end may sit from where the template expects it, and how far past it a hole
# must reach.
BRIDGE_MARGIN_M = 0.0015
BRIDGE_HOLE_M = 0.004
# Seeing past a part's end (sees_past_end): this many points (not a stray outlier or two) this far
# below the groove's bottom, beyond where depth noise puts a groove point (~0.5 mm sigma at 0.45 m,
# in 1 mm steps). A groove with less plate than that under its root is not seen past this way.
PAST_END_POINTS = 4
PAST_END_MARGIN_M = 0.002


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


def fit_or_bridge(
    surface: FineSurface, centre, travel, axis, template: GrooveTemplate | None,
    kinds: Collection[JointKind] | None = None,
) -> SectionFit:
    """The section at `centre` across `travel` (axis made perpendicular to it), fitted
    (FineSurface.fit); where no groove fits and the sections before describe the groove
    (`template`), each of these in turn: the groove fitted within half its opening +
    face_radius / 2 of the centre (where a plate edge crosses the section obliquely, the table
    beyond it sits beside the groove and spoils the surface line); the groove bridged over a
    dropout (bridge_groove); bridged over an end that crosses the groove obliquely, where the
    scan sees past the part's end within the section window's reach ahead (part_ends_ahead; up
    to 70 degrees from square such an end cuts one side tan(70) x half-opening before the seam
    line: 22 mm for an 8 mm half-opening)."""
    profile = surface.profile(centre, travel, *section_frame(travel, axis))
    fit = surface.fit_profile(profile, kinds)
    if template is None or fit.kind == GROOVE:
        return fit
    for strategy in (_near_groove, _across_dropout, _across_oblique_end):
        found = strategy(surface, profile, travel, template, kinds)
        if found is not None:
            return found
    return fit


def _near_groove(surface, profile: Profile, travel, template, kinds) -> SectionFit | None:
    if template.half_opening_m is None:
        return None
    near = np.abs(profile.u) <= template.half_opening_m + surface.params.joints.face_radius_m / 2
    narrow = Profile(profile.u[near], profile.w[near], profile.along[near], profile.centre, profile.axis,
                     profile.lateral)  # fmt: skip
    fit = surface.fit_profile(narrow, kinds)
    return fit if fit.kind == GROOVE else None


def _across_dropout(surface, profile: Profile, travel, template, kinds) -> SectionFit | None:
    if not template.edges_seen:
        return None
    bridged = bridge_groove(profile, template, surface.params.joints)
    return None if bridged is None else profile.to_3d(bridged, bridged=True)


def _across_oblique_end(surface, profile: Profile, travel, template, kinds) -> SectionFit | None:
    if not template.edges_seen or not part_ends_ahead(
        surface, profile.centre, travel, profile.axis, template, surface.params.half_width_m
    ):
        return None
    bridged = bridge_groove(profile, template, surface.params.joints, part_ends=True)
    return None if bridged is None else profile.to_3d(bridged, bridged=True)


def part_ends_ahead(surface: FineSurface, centre, travel, axis, template: GrooveTemplate, reach_m: float) -> bool:
    """Whether the scan sees past the part's end (sees_past_end) within `reach_m` ahead of
    `centre`, on the groove the template describes (its half-opening and bottom; False when
    either is unknown)."""
    if template.bottom_m is None or template.half_opening_m is None:
        return False
    ahead = SectionFit(GROOVE, centre, axis, JointGeometry(opening_m=2 * template.half_opening_m))
    return sees_past_end(surface, ahead, travel, reach_m, template.bottom_m)


def groove_template(surface: FineSurface, fit: SectionFit, travel: np.ndarray) -> GrooveTemplate:
    """The GrooveTemplate of a fitted groove section: its half-opening, and where the plate
    surface ends beside it, measured as a bridged section measures it."""
    profile = _fit_profile_points(surface, fit, travel)
    found = _surface_ends(profile.u, profile.w, fit.half_opening_m, fit.half_opening_m,
                          surface.params.joints.groove_min_depth_m)  # fmt: skip
    ends = found[1] if found is not None else {}
    return GrooveTemplate(-ends[-1] if -1 in ends else None, ends[1] if 1 in ends else None, fit.half_opening_m,
                          _bottom(profile.u, profile.w, fit.half_opening_m))  # fmt: skip


def groove_bottom(surface: FineSurface, fit: SectionFit, travel: np.ndarray) -> float | None:
    """How deep a groove fit's groove is (m below its surface line), from its section (_bottom)."""
    profile = _fit_profile_points(surface, fit, travel)
    return _bottom(profile.u, profile.w, fit.half_opening_m)


def _fit_profile_points(surface: FineSurface, fit: SectionFit, travel: np.ndarray) -> Profile:
    """The section through a fit's seam point, across `travel`, in the fit's own frame."""
    return surface.profile(fit.point_m, travel, *section_frame(travel, fit.torch_axis))


def _bottom(u: np.ndarray, w: np.ndarray, half_opening_m: float) -> float | None:
    """The upper decile of the depths -w of a groove section's points in its opening
    (|u| <= half-opening, u and w from its seam point); None with fewer than PAST_END_POINTS
    points there (a fillet has no opening)."""
    depth = -w[np.abs(u) <= half_opening_m]
    return upper_decile(depth) if len(depth) >= PAST_END_POINTS else None


def sees_past_end(surface: FineSurface, fit: SectionFit, travel: np.ndarray, reach_m: float, bottom_m: float) -> bool:
    """Whether the scan sees past the part's end within `reach_m` ahead of a groove fit: at least
    PAST_END_POINTS points ahead of its section (0 < along <= reach_m) and within its opening
    (|u| <= half-opening) lie deeper than the groove's bottom `bottom_m` + PAST_END_MARGIN_M,
    spread across at least half the opening's width. Through the opening of a groove that goes
    on, the camera sees the groove (and through a root gap, what lies behind it along the seam
    line only); past the plate's end it sees what lies behind it (the table, the floor); in a
    hole it sees nothing."""
    axis, lateral = section_frame(travel, fit.torch_axis)
    centre = fit.point_m + reach_m / 2 * travel
    nearby = surface.tree.query_ball_point(centre, reach_m / 2 + surface.params.half_width_m)
    offsets = surface.points.take(nearby, axis=0) - fit.point_m
    along, u, depth = offsets @ travel, offsets @ lateral, offsets @ axis
    ahead = (along > 0) & (along <= reach_m) & (np.abs(u) <= fit.half_opening_m)
    beyond = ahead & (depth > bottom_m + PAST_END_MARGIN_M)
    return np.count_nonzero(beyond) >= PAST_END_POINTS and np.ptp(u[beyond]) >= fit.half_opening_m


def bridge_groove(
    profile: Profile, template: GrooveTemplate, params: JointsConfig, *, part_ends: bool = False
) -> ProfileFit | None:
    """The groove in a profile where a dropout hides too much of it to fit (no model fitted),
    from where the plate surface ends on either side (_surface_ends), or None. The profile's
    `along` places each point along the seam: the surface must lie evenly on both sides of the
    section plane (a section just past the part's end is not bridged).

    The sections before give the template: the surface ends `template.left_m` left and
    `template.right_m` right of the seam point. With both ends seen (each within 1.5 mm of
    where the template puts it, and agreeing on the seam point within 3 mm), the seam is the
    mean of the two the template implies. With one seen (and measured in the template: a side
    never measured cannot place the seam), the other side must be a hole (_hole_beyond; a
    plate's outer or oblique end is not a hole), or, where the caller found the part ending just
    ahead (`part_ends`), the plate on that side must have ended while the groove's root is still
    under the seam (_plate_ended); the seam is then where the seen end puts it. The torch axis is
    perpendicular to the surface line fitted within half the opening + face_radius_m of the seam
    (to all the surface with fewer than 6 points there).
    """
    u, w = profile.u, profile.w
    left, right = template.expected(-1), template.expected(1)
    found = _surface_ends(u, w, left, right, params.groove_min_depth_m)
    if found is None or not balanced(profile.along[found[0]]):
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
        if not (_hole_beyond(u, surface, centre_u, seen, template)
                or (part_ends and _plate_ended(u, w, surface, centre_u, seen, template))):
            return None
    else:
        return None
    opening = left + right
    beside = surface & (np.abs(u - centre_u) <= opening / 2 + params.face_radius_m)
    if np.count_nonzero(beside) < 6:
        beside = surface
    intercept, slope = line(u[beside], w[beside])
    norm = np.hypot(1.0, slope)
    residual = noise(w[beside] - (intercept + slope * u[beside]))
    return ProfileFit(GROOVE, float(centre_u), intercept + slope * centre_u, slope / norm, -1.0 / norm, residual,
                      JointGeometry(opening_m=opening))  # fmt: skip


def _hidden_side(u, centre_u: float, seen: int, template: GrooveTemplate) -> tuple[np.ndarray, float]:
    """(distance of each point beyond the seam on the side not seen, where that side's surface
    end is expected) for a groove at `centre_u` whose end on side `seen` (-1 or 1) was seen."""
    return -seen * (u - centre_u), template.expected(-seen)


def _hole_beyond(u, surface, centre_u: float, seen: int, template: GrooveTemplate) -> bool:
    """Whether a groove's hidden side is a hole: no points from BRIDGE_MARGIN_M inside to
    BRIDGE_HOLE_M outside its expected surface end, and surface again beyond."""
    hidden, expected_m = _hidden_side(u, centre_u, seen, template)
    if np.any((hidden > expected_m - BRIDGE_MARGIN_M) & (hidden < expected_m + BRIDGE_HOLE_M)):
        return False
    return np.count_nonzero(surface & (hidden >= expected_m + BRIDGE_HOLE_M)) >= 4


def _plate_ended(u, w, surface, centre_u: float, seen: int, template: GrooveTemplate) -> bool:
    """Whether the plate on a groove's hidden side has ended (an end crossing the groove
    obliquely) while the groove's root still lies under the seam: no surface point on that side
    beyond BRIDGE_MARGIN_M inside its expected end, and at least 4 points within BRIDGE_MARGIN_M
    of the seam line up to PAST_END_MARGIN_M above the groove's bottom, none counted below it
    (past a square end, the table under a thin root face lies just below the root and must not
    pass for it)."""
    hidden, expected_m = _hidden_side(u, centre_u, seen, template)
    if template.bottom_m is None or np.any(surface & (hidden > expected_m - BRIDGE_MARGIN_M)):
        return False
    intercept, slope = line(u[surface], w[surface])
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
    intercept, slope = line(u[near_surface], w[near_surface])
    residual = w - (intercept + slope * u)
    tolerance = max(3 * noise(residual[near_surface]), 0.4 * groove_min_depth_m)
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
