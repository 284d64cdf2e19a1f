"""A seam that turns over a 90-degree edge: off a block's top and down its side, or from the
floor up a wall."""

from __future__ import annotations

import numpy as np

from weldseam.geometry import unit
from weldseam.pipeline.seek import Extension, next_fit, section_at

# A turn over an edge counts once the seam goes on this far along the new face.
TURN_CONFIRM_M = 0.024


def turned_run(extension: Extension, last_point, last_axis, direction):
    """(fits, new direction) of the seam on the face beyond a 90-degree edge, or None.

    Over a convex edge (off a block's top, down its side) the travel turns into the old torch axis
    and the torch axis into minus the old travel; at a concave corner (from the floor up a wall)
    the travel turns against the old torch axis and the torch axis into the old travel. The edge
    is sought up to edge_search_m ahead in two-step strides; the first fit, three steps past it,
    must sit on the turned line within 1.5 steps sideways and one step in depth (half the
    stride), and the seam must go on along the new face for TURN_CONFIRM_M: a plate's end face
    (under 12 mm tall) shows the groove's walls receding like a groove for a few sections, a
    block's side carries the seam on.
    """
    step = extension.params.step_m
    axis = unit(last_axis - (last_axis @ direction) * direction)
    for travel, new_axis in ((axis, -direction), (-axis, direction)):
        for edge in np.arange(0.0, extension.params.edge_search_m + step, 2 * step):
            corner = last_point + edge * direction
            fit, depth, sideways = section_at(extension, corner + 3 * step * travel, travel, new_axis)
            if fit.kind != extension.joint or sideways > 1.5 * step or depth > step:
                continue
            run = [fit]
            while np.linalg.norm(run[-1].point_m - run[0].point_m) < TURN_CONFIRM_M:
                following = next_fit(extension, run[-1].point_m, run[-1].torch_axis, (travel, np.zeros(3)))
                if following is None:
                    break
                run.append(following)
            else:
                return run, travel
    return None
