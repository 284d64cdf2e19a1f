"""Joint models: each fits a cross-section profile and returns the seam point, the torch axis,
a residual and the measured geometry, or no fit with the reason.

A model is a module with `KIND` (a JointKind), `CENTRED` (whether its fit assumes the joint in the
middle of the section window), `MIN_LENGTH_M` (the shortest seam of its kind, m, between sharp
corners; 0: as short as split.min_seam_length_m allows), `SPECIALISES` (the kind it is a special
case of, or None) and `fit(profile: SortedProfile) -> ProfileFit | NoFit`, the fit with its
outline. Every model of a section reads one SortedProfile, which computes what several of them
derive (the plate surface line) once. Adding a joint kind means adding one model module and its
entry in MODELS.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import replace

import numpy as np

from weldseam.config import JointsConfig
from weldseam.pipeline.joints import bevel, fillet, lap, outside_corner, square_butt, v_groove
from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit, outline_residual
from weldseam.pipeline.joints.profile import NO_OPENINGS, SortedProfile

__all__ = ["MODELS", "JointGeometry", "JointKind", "NoFit", "ProfileFit", "SortedProfile", "akin", "fit_profile", "min_length_m", "one_joint", "recentred"]

MODELS = (v_groove, fillet, lap, square_butt, bevel, outside_corner)
MIN_PROFILE_POINTS = 12
# A fit whose outline lies farther than this from the section's points (median, the depth of the
# shallowest groove that counts) explains nothing: what fitted is a few points of something else.
MAX_OUTLINE_RESIDUAL_M = 0.0015
# A special case's outline within this fraction of the general kind's residual explains the points
# as well (noise decides between them): a single bevel whose bevel wall is seen is also a V-groove
# with its square wall hidden, and the V-groove's outline follows the bevel within the noise.
TIE_FRACTION = 0.2
# A groove fitted without a measured flank (no wall slope seen: geometry.included_deg None) says
# no more of the section than an opening with square sides does: seen obliquely, a square butt's
# gap shows one square wall, and a V-groove or a bevel with its other wall hidden draws the same
# outline. The square butt, which also needs the two faces coplanar and the opening clean, is the
# joint when its outline lies within TIE_FRACTION of such a fit's.
SQUARE_OPENING = JointKind.SQUARE_BUTT
FLANKED = frozenset({JointKind.V_GROOVE, JointKind.BEVEL})
# The joints whose seam point lies on the part's surfaces, where two faces meet inside (a groove's
# lies in the air over its opening, an outside corner's in its V): where a part stands on the
# table such a seam lies on the table (support), and where the camera sees past the seam line the
# part has ended (extend).
ON_SURFACE = frozenset({JointKind.FILLET, JointKind.LAP})


def fit_profile(
    u: np.ndarray, w: np.ndarray, params: JointsConfig, kinds: Collection[JointKind] | None = None,
    openings_u: np.ndarray = NO_OPENINGS, toward: tuple[float, float] | None = None,
) -> ProfileFit | NoFit:
    """The joint in one profile (u lateral, w height out of the work, m), or NoFit with every
    model's reason; `kinds`: only these models are tried (None: all); `openings_u`: where the
    sensor's image shows an opening in the section, `toward`: the direction to the single camera
    (SortedProfile). Of the models that fit, the
    one whose outline lies closest to the profile's points around its seam (outline_residual,
    within face_radius_m + half its opening) is the joint, its residual_m that distance; on a tie,
    the first in MODELS. A fit of a kind that SPECIALISES the closest one's kind, within
    TIE_FRACTION of its residual, is the joint instead: it says more of the same points; so is a
    square butt fit against a V-groove or bevel that measured no flank (see SQUARE_OPENING)."""
    if len(u) < MIN_PROFILE_POINTS:
        return NoFit("too few points in the section")
    profile = SortedProfile.of(u, w, params, openings_u, toward)
    u, w = profile.u, profile.w
    reasons, fits = [], []
    for model in MODELS:
        if kinds is not None and model.KIND not in kinds:
            continue
        found = model.fit(profile)
        if isinstance(found, NoFit):
            reasons.append(f"{model.KIND.value}: {found.reason}")
            continue
        reach = params.face_radius_m + found.half_opening_m
        residual = outline_residual(u, w, found.outline, found.u, reach)
        if residual > MAX_OUTLINE_RESIDUAL_M:
            reasons.append(f"{model.KIND.value}: its outline lies {residual * 1000:.1f} mm from the points")
            continue
        fits.append(replace(found, residual_m=residual))
    if not fits:
        return NoFit("; ".join(reasons))
    closest = min(fits, key=lambda fit: fit.residual_m)
    special = [fit for fit in fits if _says_more(fit, closest)
               and fit.residual_m <= closest.residual_m * (1 + TIE_FRACTION)]  # fmt: skip
    return min(special, key=lambda fit: fit.residual_m) if special else closest


def _says_more(fit: ProfileFit, closest: ProfileFit) -> bool:
    """Whether `fit` explains the section better than `closest` when as close to its points: a
    special case of its kind, or a square opening against a groove without a measured flank."""
    if _specialises(fit.kind, closest.kind):
        return True
    return fit.kind == SQUARE_OPENING and closest.kind in FLANKED and closest.geometry.included_deg is None


def recentred(kind: JointKind) -> bool:
    """Whether a fit of this kind assumes the joint in the middle of its window (its model's
    CENTRED), so a fit far off the window's centre is fitted again centred on it."""
    return next(model.CENTRED for model in MODELS if model.KIND == kind)


def one_joint(kind: JointKind, other: JointKind) -> bool:
    """Whether seams of these kinds may be pieces of one joint: the same kind, or one a special
    case of the other (a V-groove whose one wall looks square over a stretch is still one groove)."""
    return kind == other or _specialises(kind, other) or _specialises(other, kind)


def _specialises(kind: JointKind, general: JointKind) -> bool:
    """Whether `kind`'s model is a special case of `general` (its SPECIALISES)."""
    return next(model.SPECIALISES for model in MODELS if model.KIND == kind) == general


def akin(kinds: Collection[JointKind]) -> frozenset[JointKind]:
    """`kinds` with the kinds each is a special case of, or that are special cases of it (a bevel
    is a V-groove with one square wall): what a section of one of them may turn out to be."""
    return frozenset(
        model.KIND for model in MODELS
        if model.KIND in kinds or model.SPECIALISES in kinds or any(_specialises(kind, model.KIND) for kind in kinds)
    )


def min_length_m(kind: JointKind) -> float:
    """The shortest seam of this kind (its model's MIN_LENGTH_M, m)."""
    return next(model.MIN_LENGTH_M for model in MODELS if model.KIND == kind)
