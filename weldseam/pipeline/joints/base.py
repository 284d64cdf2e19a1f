"""What every joint model shares: the kinds, the parameters, and a fit or the reason for none.

A model fits one cross-section profile: u (m) lateral, across the seam; w (m) height out of
the work (minus the approximate torch axis). Points come sorted by u.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from weldseam.pipeline.joints.robust import middle


class JointKind(str, Enum):
    """The joint kinds weldseam plans; the value is the name written in path files."""

    V_GROOVE = "v_groove"
    FILLET = "fillet"
    LAP = "lap"
    SQUARE_BUTT = "square_butt"
    BEVEL = "bevel"
    OUTSIDE_CORNER = "outside_corner"


@dataclass(frozen=True)
class JointGeometry:
    """What a fit measured of the joint (None: not measured for this kind): the opening's width
    at the surface (m), the depth below the surface (m), the included angle between the two
    walls or faces (degrees), the two legs (m, left and right of the seam), and how many of the
    joint's two faces the scan saw (one: the other was placed from what the camera saw past it) and
    whether that was an occluder's outline rather than a wall's top running along the seam."""

    opening_m: float | None = None
    depth_m: float | None = None
    included_deg: float | None = None
    legs_m: tuple[float, float] | None = None
    faces_seen: int = 2
    outline_wall: bool = False

    @property
    def across_spread(self) -> float:
        """How much farther across the seam than in depth the meeting point of two faces moves when
        a face moves in depth (noise, ripple): max(1, 1 / tan a), a = (180 - included) / 2 the
        faces' slope from the lateral (a face raised by d moves the corner d / 2 tan a across and
        d / 2 in depth); 1 without a measured angle. A 130-degree valley's corner is known 2.1 times
        less well across than its faces are in depth, a 150-degree one's 3.7 times. 1 for a groove:
        its point is its opening's middle, between two edges, not where its walls meet; and for a
        corner with one face unseen: its point is where the seen face ends."""
        if self.included_deg is None or self.included_deg <= 90.0 or self.opening_m or self.faces_seen == 1:
            return 1.0
        return 1.0 / float(np.tan(np.radians(180.0 - self.included_deg) / 2))


@dataclass(frozen=True)
class ProfileFit:
    """A joint found in a profile: the seam point (u, w) (m), the unit torch axis (axis_u, axis_w)
    pointing into the work, the fit's robust residual (m), the measured geometry, and the model's
    outline: the (u, w) vertices of the surface it fitted, left to right, its first and last
    segments running on as rays (joints.outline_residual compares models by it)."""

    kind: JointKind
    u: float
    w: float
    axis_u: float
    axis_w: float
    residual_m: float
    geometry: JointGeometry
    outline: tuple[tuple[float, float], ...] = field(default=(), compare=False)

    @property
    def half_opening_m(self) -> float:
        """Half the opening's width (m); 0 for a joint without one."""
        return 0.0 if self.geometry.opening_m is None else self.geometry.opening_m / 2


@dataclass(frozen=True)
class NoFit:
    """No joint in the profile, and why (for the record of rejected candidates)."""

    reason: str


def outline_residual(u: np.ndarray, w: np.ndarray, outline, centre_u: float, reach_m: float) -> float:
    """Median distance (m) of the profile points within `reach_m` of `centre_u` (across) to a
    model's outline (ProfileFit.outline; its end segments run on as rays): how well the model
    explains the profile around its seam, comparable between models."""
    near = np.abs(u - centre_u) <= reach_m
    if len(outline) < 2 or not near.any():
        return float("inf")
    points = np.column_stack([u[near], w[near]])
    vertices = np.asarray(outline, dtype=np.float64)
    starts, ends = vertices[:-1], vertices[1:]
    along = ends - starts
    length_sq = np.maximum(np.einsum("ij,ij->i", along, along), 1e-18)
    t = np.einsum("pij,ij->pi", points[:, None, :] - starts[None], along) / length_sq
    low = np.full(len(starts), 0.0)
    high = np.full(len(starts), 1.0)
    low[0], high[-1] = -np.inf, np.inf  # the end segments run on
    closest = starts[None] + np.clip(t, low, high)[:, :, None] * along[None]
    distance = np.linalg.norm(points[:, None, :] - closest, axis=2).min(axis=1)
    return middle(distance)
