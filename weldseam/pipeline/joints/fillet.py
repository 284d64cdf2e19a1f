"""The fillet model (inside corner): two faces meeting at a concave corner.

Two lines, left and right of a break (the break minimising the total squared error), both
rising away from the corner, at an included angle of 45-135 degrees, each face at least
`fillet_min_leg_m` long. The seam point is the corner; the torch axis is the bisector of the
two faces, pointing into the corner.
"""

from __future__ import annotations

import numpy as np

from weldseam.geometry import unit
from weldseam.config import JointsConfig
from weldseam.pipeline.joints.base import JointGeometry, JointKind, NoFit, ProfileFit
from weldseam.pipeline.joints.robust import line, noise

KIND = JointKind.FILLET
# Where two fitted lines meet does not depend on where the window sits.
CENTRED = False
MIN_LENGTH_M = 0.0
SPECIALISES = None
MIN_INCLUDED_DEG = 45.0
MAX_INCLUDED_DEG = 135.0
# A face is only as long as the stretch its points fill with gaps of at most this.
MAX_FACE_SPACING_M = 0.004


def fit(u: np.ndarray, w: np.ndarray, params: JointsConfig) -> ProfileFit | NoFit:
    """The inside corner in a profile (u ascending), or why there is none."""
    n = len(u)
    splits = np.arange(5, n - 4)
    if len(splits) == 0:
        return NoFit("too few points for two faces")
    # Running sums of 1, u, w, u^2, uw, w^2 (one column each; a cumulative sum runs in order).
    sums = np.cumsum(np.column_stack([np.ones(n), u, w, u * u, u * w, w * w]), axis=0)
    left = sums[splits - 1]
    right = sums[-1] - left
    error = _segment_error(*left.T) + _segment_error(*right.T)
    best = int(np.argmin(error))
    split = int(splits[best])
    faces = []
    for part in (slice(0, split), slice(split, n)):
        pu, pw = u[part], w[part]
        intercept, slope = line(pu, pw)
        residual = pw - (intercept + slope * pu)
        inliers = np.abs(residual) <= max(3 * noise(residual), 0.0005)
        if inliers.mean() < 0.8 or np.count_nonzero(inliers) < 5:
            return NoFit("a face is not a straight line")
        faces.append((*line(pu[inliers], pw[inliers]), pu[inliers]))
    (a1, b1, u1), (a2, b2, u2) = faces
    if not (b1 < 0 < b2):  # concave: both faces rise away from the corner
        return NoFit("the two faces do not form a concave corner")
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
    if not (MIN_INCLUDED_DEG <= included <= MAX_INCLUDED_DEG):
        return NoFit("the faces' included angle is outside 45-135 degrees")
    if min(leg_left, leg_right) < params.fillet_min_leg_m:
        return NoFit("a face is shorter than joints.fillet_min_leg_m")
    axis = -unit(to_left + to_right)
    residual_m = float(np.sqrt(max(error[best], 0.0) / n))
    geometry = JointGeometry(included_deg=float(included), legs_m=(leg_left, leg_right))
    outline = ((corner_u - 1.0, corner_w - b1), (corner_u, corner_w), (corner_u + 1.0, corner_w + b2))
    return ProfileFit(KIND, float(corner_u), float(corner_w), float(axis[0]), float(axis[1]), residual_m, geometry,
                      tuple((float(a), float(b)) for a, b in outline))  # fmt: skip


def _face_extent(u, w, corner_u, corner_w, direction) -> float:
    """How far a face reaches from the corner along `direction`, counting only a stretch
    its points fill with gaps of at most MAX_FACE_SPACING_M."""
    along = np.sort((u - corner_u) * direction[0] + (w - corner_w) * direction[1])
    gaps = np.flatnonzero(np.diff(along) > MAX_FACE_SPACING_M)
    start = along[gaps[-1] + 1] if len(gaps) else along[0]
    return float(along[-1] - max(start, 0.0)) if along[-1] > 0 else 0.0


def _segment_error(count, su, sw, suu, suw, sww):
    """Residual sum of squares of the least-squares line through a segment, from its sums."""
    var_u = suu - su * su / count
    cov = suw - su * sw / count
    var_w = sww - sw * sw / count
    return var_w - np.divide(cov * cov, var_u, out=np.zeros_like(cov), where=var_u > 1e-12)
