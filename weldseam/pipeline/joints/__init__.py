"""Joint models: each fits a cross-section profile and returns the seam point, the torch axis,
a residual and the measured geometry, or no fit with the reason.

A model is a module with `KIND` (a JointKind), `CENTRED` (whether its fit assumes the joint in the
middle of the section window), `MIN_LENGTH_M` (the shortest seam of its kind, m; 0: as short as
split.min_seam_length_m allows) and `fit(u, w, params) -> ProfileFit | NoFit` (u ascending), the
fit with its outline. Adding a joint kind means adding one model module and its entry in MODELS.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import replace

import numpy as np

from weldseam.pipeline.joints import fillet, lap, square_butt, v_groove
from weldseam.config import JointsConfig
from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit, outline_residual

__all__ = ["MODELS", "min_length_m", "recentred", "JointGeometry", "JointKind", "NoFit", "ProfileFit", "fit_profile"]

MODELS = (v_groove, fillet, lap, square_butt)
MIN_PROFILE_POINTS = 12


def fit_profile(
    u: np.ndarray, w: np.ndarray, params: JointsConfig, kinds: Collection[JointKind] | None = None
) -> ProfileFit | NoFit:
    """The joint in one profile (u lateral, w height out of the work, m), or NoFit with every
    model's reason; `kinds`: only these models are tried (None: all). Of the models that fit, the
    one whose outline lies closest to the profile's points around its seam (outline_residual,
    within face_radius_m + half its opening) is the joint, its residual_m that distance; on a tie,
    the first in MODELS."""
    if len(u) < MIN_PROFILE_POINTS:
        return NoFit("too few points in the section")
    order = np.argsort(u, kind="stable")
    u, w = u[order], w[order]
    reasons, fits = [], []
    for model in MODELS:
        if kinds is not None and model.KIND not in kinds:
            continue
        found = model.fit(u, w, params)
        if isinstance(found, NoFit):
            reasons.append(f"{model.KIND.value}: {found.reason}")
            continue
        reach = params.face_radius_m + found.half_opening_m
        fits.append(replace(found, residual_m=outline_residual(u, w, found.outline, found.u, reach)))
    if not fits:
        return NoFit("; ".join(reasons))
    return min(fits, key=lambda fit: fit.residual_m)


def recentred(kind: JointKind) -> bool:
    """Whether a fit of this kind assumes the joint in the middle of its window (its model's
    CENTRED), so a fit far off the window's centre is fitted again centred on it."""
    return next(model.CENTRED for model in MODELS if model.KIND == kind)


def min_length_m(kind: JointKind) -> float:
    """The shortest seam of this kind (its model's MIN_LENGTH_M, m)."""
    return next(model.MIN_LENGTH_M for model in MODELS if model.KIND == kind)
