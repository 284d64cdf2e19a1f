"""Nested seams: what lies inside a groove's opening is the groove's own geometry.

A V-groove's or single bevel's opening is air above its walls: no other joint lies in it. Seen in
a narrow section window, a groove's wall and its bottom (or its root gap) make a lap's step or a
corner; a seam of another kind whose points lie mostly inside a groove's opening is dropped.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import section_frames
from weldseam.pipeline.trace import TracedSeam

GROOVES = frozenset({JointKind.V_GROOVE, JointKind.BEVEL})
# A seam with at least this share of its points inside a groove is inside it.
INSIDE_SHARE = 0.8
# A groove is at most this many times its opening deep (a V including 40 degrees or more: 1.37).
DEPTH_PER_OPENING = 1.5
# A point this far above a groove's opening, or past its ends along it, still counts as in it (m).
MARGIN_M = 0.001


def outside_grooves(seams: list[TracedSeam]) -> list[TracedSeam]:
    """The seams but those of another kind lying inside a groove's opening (inside)."""
    grooves = [seam for seam in seams if seam.joint in GROOVES and seam.half_opening_m > 0]
    return [seam for seam in seams
            if seam.joint in GROOVES or not any(inside(seam, groove) for groove in grooves)]  # fmt: skip


def inside(seam: TracedSeam, groove: TracedSeam) -> bool:
    """Whether INSIDE_SHARE of `seam`'s points lie inside `groove`'s opening: at its nearest point,
    in its section frame there (section_frames: travel, torch axis, lateral; a loop's travel runs on
    across its closing segment), within its half-opening across, from MARGIN_M
    above its opening down to DEPTH_PER_OPENING times its opening along its torch axis, and within
    MARGIN_M of it along its travel."""
    if len(groove.positions_m) < 2:
        return False
    nearest = cKDTree(groove.positions_m).query(seam.positions_m)[1]
    frames = section_frames(groove.positions_m, groove.torch_axes, groove.closed)
    offset = seam.positions_m - groove.positions_m[nearest]
    along, depth, across = (np.einsum("ij,ij->i", offset, frame[nearest]) for frame in frames)
    opening = 2 * groove.half_opening_m
    within = (np.abs(across) <= groove.half_opening_m) & (depth >= -MARGIN_M) & (depth <= DEPTH_PER_OPENING * opening)
    within &= np.abs(along) <= MARGIN_M + float(np.linalg.norm(np.diff(groove.positions_m, axis=0), axis=1).max())
    return np.count_nonzero(within) >= INSIDE_SHARE * len(seam.positions_m)
