import numpy as np


def crease_points(angle_deg, spacing, half_extent=0.05):
    """Two half-planes meeting along the y axis at `angle_deg` (0 = a plane)."""
    ticks = np.arange(-half_extent, half_extent, spacing)
    u, v = (a.ravel() for a in np.meshgrid(ticks, ticks))
    return np.column_stack([u, v, np.where(u > 0, u * np.tan(np.radians(angle_deg)), 0.0)])
