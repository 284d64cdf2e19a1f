"""Seeking a seam ahead of a known end: the sections an extension tries, and when a fit counts."""

from __future__ import annotations

from dataclasses import dataclass

from weldseam.config import ExtendConfig
from weldseam.pipeline.bridge import GrooveTemplate, fit_or_bridge
from weldseam.pipeline.carried import CornerTemplate, carried_fit
from weldseam.pipeline.ends import SeamLine, ahead, offsets, sideways_reach_m
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import FineSurface, SectionFit


@dataclass(frozen=True)
class Extension:
    """What an extension seeks: the surface it fits sections on, the seam's joint, the parameters."""

    surface: FineSurface
    joint: JointKind
    params: ExtendConfig


def next_fit(extension: Extension, last_point, last_axis, heading,
             template: GrooveTemplate | CornerTemplate | None = None, line: SeamLine | None = None,
             end_spread: float | None = None):
    """The next fit along the curve predicted from the end (ends.ahead of `heading`: (direction,
    bend)), stepping over failed sections up to max_skip_m, or None. Where a section fails and
    the groove's template is known, it is bridged (a dropout over part of the groove:
    bridge.fit_or_bridge); with a corner's template, each section is fitted as a corner with one
    face carried on from the template alone (carried.carried_fit).

    A fit counts when it lies within max(1.5 steps, 15 % of the distance from the last fit) of the
    prediction sideways (the fit is a verified joint profile and the better estimate: near an end
    the prediction drifts by 1-3 mm; the bound follows curves of radius down to ~40 mm across the
    largest gap), and within max(half a step, 20 % of the distance) along the torch axis (the
    surface does not jump, a section that straddles the part's end face does; but an end tangent
    fitted to end points that drift in depth leans into the work, 1-2 mm over a 12 mm gap).

    A fit off that curve also counts within 1.5 steps sideways and half a step in depth of the
    seam's straight `line` (None: no such line) over its last stretch (ends.SeamLine): the curve's
    direction rests on the last few fits, and where those drift by a millimetre (the fits at a
    plate's end, beside a table) it turns 5-15 degrees off the seam, 3 mm sideways within two
    steps; the line over TANGENT_BASELINE_M is not turned by them.

    Every bound is widened by the fit's across_spread: a shallow corner's point is known that
    much less well across than its faces are in depth, and where its fits scatter across (a
    valley of 130-150 degrees in a sensor's ripple: 2-4 mm), the curve predicted through them
    leans by as much, across and, as it rises or falls with them, in depth. A fit widens them no
    more than the seam's end does (`end_spread`, its last fit's; None: the fit's own): a fit of a
    flatter corner than the seam's would otherwise take itself 5-6 times as far sideways (a
    160-degree "corner" of ripple on a tube beside the valley, 14 mm off it)."""
    step = extension.params.step_m
    direction, bend = heading
    distance = step
    while distance <= extension.params.max_skip_m:
        predicted, travel = ahead(last_point, direction, bend, distance)
        fit, depth, sideways = section_at(extension, predicted, travel, last_axis, template)
        spread = fit.geometry.across_spread if end_spread is None else min(fit.geometry.across_spread, end_spread)
        near = (sideways <= sideways_reach_m(step, distance) * spread
                and depth <= max(0.5 * step, 0.2 * distance) * spread)
        on_line = line is not None and line.holds(fit.point_m, last_axis, step * spread)
        if fit.kind == extension.joint and (near or on_line):
            return fit
        distance += step
    return None


def section_at(extension: Extension, predicted, travel, axis, template: GrooveTemplate | CornerTemplate | None = None):
    """(fit, depth, sideways) of the section at `predicted` seeking the extension's joint (bridged
    with a groove's template where it does not fit; with a corner's, the corner carried on);
    depth and sideways are the fit's offsets (m) from the prediction along and across the axis."""
    if isinstance(template, CornerTemplate):
        fit = carried_fit(extension.surface, predicted, travel, axis, template)
    else:
        fit = fit_or_bridge(extension.surface, predicted, travel, axis, template, {extension.joint})
    return fit, *offsets(fit.point_m, predicted, travel, axis)



def plain_fit(extension: Extension, centre, travel, axis) -> SectionFit:
    """The section at `centre` fitted for the extension's joint alone (no bridging)."""
    return extension.surface.fit(centre, travel, axis, {extension.joint})
