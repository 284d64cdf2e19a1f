"""Apart: an inside corner between two parts that do not touch is no joint.

Behind each face of a joint lies its part's material: the scan sees no surface there. A clamp's
post stands 3-8 mm beside a block, its side turned to the block's side: seen past the post's
edge, the block's face runs on beyond the corner the two faces' lines make, behind the post's
face, and the post's face ends in a jump in depth, in front of it. The fillet model fits the
two faces as a corner (broad block_groove 9: a 97 mm vertical "fillet" up the post). A corner
one of whose faces runs on behind the other, by more than noise and over a few mm, at most of
its sections, is two parts standing apart (`standing_apart`).
"""

from __future__ import annotations

import numpy as np

from weldseam.pipeline.joints import JointKind, ProfileFit, fit_profile
from weldseam.pipeline.section import FineSurface, section_frames
from weldseam.pipeline.trace import TracedSeam

# Sections read along a seam (evenly spaced), and the fewest that must fit its corner.
SAMPLES = 15
MIN_MEASURED = 3
# A point this far behind the corner's outline (into where the part's material would be) is a
# surface seen behind a face: well beyond a sensor's noise and ripple (~0.5 mm).
BEHIND_M = 0.002
# The surface seen behind a face must span this much of the profile (at the section's point
# density) for the face to run on behind the other: a few stray points at a depth jump do not.
BEHIND_RUN_M = 0.003


def joined_seams(seams: list[TracedSeam], surface: FineSurface) -> list[TracedSeam]:
    """The seams but the inside corners between two parts standing apart (standing_apart)."""
    return [seam for seam in seams if not standing_apart(seam, surface)]


def standing_apart(seam: TracedSeam, surface: FineSurface) -> bool:
    """Whether an inside corner (a fillet) is two parts standing apart: at up to SAMPLES sections
    along it, fitted again as a fillet, the profile points within face_radius_m of the corner (in
    u) lying more than BEHIND_M below the fit's outline are counted; it is when at least
    MIN_MEASURED sections fit and their median count reaches BEHIND_RUN_M of profile, at the
    section's point density (min_points over the window's width)."""
    if seam.joint != JointKind.FILLET:
        return False
    params = surface.params
    travel, axes, lateral = section_frames(seam.positions_m, seam.torch_axes, seam.closed)
    picks = seam.samples(SAMPLES)
    behind = []
    for k in picks:
        profile = surface.profile(seam.positions_m[k], travel[k], axes[k], lateral[k])
        fit = fit_profile(profile.u, profile.w, params.joints, {JointKind.FILLET})
        if isinstance(fit, ProfileFit):
            behind.append(points_behind(profile.u, profile.w, fit, params.joints.face_radius_m))
    run_points = BEHIND_RUN_M * params.min_points / (2.0 * params.half_width_m)
    return len(behind) >= MIN_MEASURED and float(np.median(behind)) >= run_points


def points_behind(u: np.ndarray, w: np.ndarray, fit: ProfileFit, reach_m: float) -> int:
    """How many of the profile's points (u across, w out of the work, m) within reach_m of the
    fit's seam point across lie more than BEHIND_M below its outline (the outline's height at
    their u, linearly between its vertices, u increasing left to right)."""
    outline = np.array(fit.outline)
    near = np.abs(u - fit.u) <= reach_m
    return int(np.count_nonzero(np.interp(u[near], outline[:, 0], outline[:, 1]) - w[near] > BEHIND_M))
