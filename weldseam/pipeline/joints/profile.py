"""A cross-section profile as the joint models read it: its points sorted across the seam, the
models' parameters, and what several models derive from the points, computed once when first
asked.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from weldseam.config import JointsConfig
from weldseam.pipeline.joints.base import NoFit
from weldseam.pipeline.joints.robust import line, noise

# The least noise a plate surface is taken to have: depth quantised in 1 mm steps (RealSense
# and most structured-light cameras), seen square on, leaves most of a flat surface on one level
# and the next 1 mm below; the median deviation is then ~0 and that level would pass for a
# depression. 1 mm / sqrt(12) = 0.29 mm.
SURFACE_NOISE_FLOOR_M = 0.0003
# No opening known in a section (read-only: every profile without one shares it).
NO_OPENINGS = np.empty(0)
NO_OPENINGS.flags.writeable = False


class PlateSurface(NamedTuple):
    """The plate surface line w = intercept + slope u through a profile: which points lie on it,
    each point's residual w - line (m, (N,)), the depth below it that counts as a depression
    (m) and the surface's robust noise sigma (m)."""

    intercept: float
    slope: float
    on_surface: np.ndarray
    residual: np.ndarray
    depth_limit: float
    sigma: float


@dataclass(frozen=True, eq=False)
class SortedProfile:
    """One section's points, u (N,) lateral and ascending, w (N,) height out of the work (m), with
    the joint models' parameters, the u (m) of the openings the sensor's image shows across
    the section (a square butt's gap returning no pixels: gaps.gap_midpoints; none known: empty)
    and the unit (u, w) direction toward the single camera that saw it (None: no single camera);
    every model of one section reads the same value."""

    u: np.ndarray
    w: np.ndarray
    params: JointsConfig
    openings_u: np.ndarray = field(default_factory=lambda: NO_OPENINGS)
    toward: tuple[float, float] | None = None

    @classmethod
    def of(
        cls, u: np.ndarray, w: np.ndarray, params: JointsConfig, openings_u: np.ndarray = NO_OPENINGS,
        toward: tuple[float, float] | None = None,
    ) -> SortedProfile:
        """The profile of points (u, w) in any order (a stable sort by u)."""
        order = np.argsort(u, kind="stable")
        return cls(u[order], w[order], params, openings_u, toward)

    @cached_property
    def surface(self) -> PlateSurface | NoFit:
        """The plate surface line (the V-groove, the bevel and the square butt each start from
        it), or NoFit: an upper envelope, started from the outer halves, that repeatedly ignores
        points below the line (deeper than max(3 sigma, 0.4 joints.groove_min_depth_m)). Its
        arrays are read-only: the models share them."""
        found = _surface_line(self.u, self.w, self.params.groove_min_depth_m)
        if not isinstance(found, NoFit):
            found.on_surface.flags.writeable = False
            found.residual.flags.writeable = False
        return found


def _surface_line(u: np.ndarray, w: np.ndarray, min_depth_m: float) -> PlateSurface | NoFit:
    half_width = max(abs(u[0]), abs(u[-1]))
    on_surface = np.abs(u) > half_width / 2
    if np.count_nonzero(on_surface) < 6:
        return NoFit("too few points beside the section centre")
    for _ in range(6):
        intercept, slope = line(u[on_surface], w[on_surface])
        residual = w - (intercept + slope * u)
        sigma = max(noise(residual[on_surface]), SURFACE_NOISE_FLOOR_M)
        depth_limit = max(3 * sigma, 0.4 * min_depth_m)
        updated = (residual > -depth_limit) & (residual < 4 * sigma + depth_limit)
        if np.count_nonzero(updated) < 6 or np.array_equal(updated, on_surface):
            break
        on_surface = updated
    return PlateSurface(intercept, slope, on_surface, residual, depth_limit, sigma)
