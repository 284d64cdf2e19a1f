"""What every joint model shares: the kinds, the parameters, and a fit or the reason for none.

A model fits one cross-section profile: u (m) lateral, across the seam; w (m) height out of
the work (minus the approximate torch axis). Points come sorted by u.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class JointKind(str, Enum):
    """The joint kinds weldseam plans; the value is the name written in path files."""

    V_GROOVE = "v_groove"
    FILLET = "fillet"


@dataclass(frozen=True)
class JointGeometry:
    """What a fit measured of the joint (None: not measured for this kind): the opening's width
    at the surface (m), the depth below the surface (m), the included angle between the two
    walls or faces (degrees) and the two legs (m, left and right of the seam)."""

    opening_m: float | None = None
    depth_m: float | None = None
    included_deg: float | None = None
    legs_m: tuple[float, float] | None = None


@dataclass(frozen=True)
class ProfileFit:
    """A joint found in a profile: the seam point (u, w) (m), the unit torch axis (axis_u, axis_w)
    pointing into the work, the fit's robust residual (m) and the measured geometry."""

    kind: JointKind
    u: float
    w: float
    axis_u: float
    axis_w: float
    residual_m: float
    geometry: JointGeometry

    @property
    def half_opening_m(self) -> float:
        """Half the opening's width (m); 0 for a joint without one."""
        return 0.0 if self.geometry.opening_m is None else self.geometry.opening_m / 2


@dataclass(frozen=True)
class NoFit:
    """No joint in the profile, and why (for the record of rejected candidates)."""

    reason: str
