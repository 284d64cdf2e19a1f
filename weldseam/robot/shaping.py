"""Path modifiers for the torch: small pure functions WeldPath -> WeldPath (or poses -> values).

Tool frame convention (weldseam.types.WeldPath): column 1 = y = travel direction, column 2 = z =
torch axis pointing INTO the work, column 0 = x = y cross z (across the seam).
Apply tilts before the standoff so the torch tip stays on the seam point.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from weldseam.types import WeldPath

BLEND_MARGIN_M = 1e-5


def to_robot_base(path: WeldPath, base_pose: np.ndarray) -> WeldPath:
    """Express the path in the robot base frame; base_pose (4, 4) = scan base frame in the robot base frame."""
    rotation, translation = base_pose[:3, :3], base_pose[:3, 3]
    return replace(
        path,
        positions_m=path.positions_m @ rotation.T + translation,
        rotations=np.einsum("ij,kjl->kil", rotation, path.rotations),
    )


def with_standoff(path: WeldPath, standoff_m: float) -> WeldPath:
    """Move each pose standoff_m back along its torch axis: p' = p - standoff_m * z (rotations unchanged)."""
    return replace(path, positions_m=path.positions_m - standoff_m * path.rotations[:, :, 2])


def _tilted(path: WeldPath, local_axis: int, angle_rad: float) -> WeldPath:
    rotation = Rotation.from_rotvec(angle_rad * np.eye(3)[local_axis]).as_matrix()
    return replace(path, rotations=path.rotations @ rotation)


def with_work_angle(path: WeldPath, work_angle_deg: float) -> WeldPath:
    """Rotate the torch about its travel direction (local y) by work_angle_deg: z turns toward +x for a
    positive angle (a side that flips with the travel: work_angle.work_angle_rule gives the signed
    angle that keeps a joint kind's side); positions unchanged."""
    return _tilted(path, 1, np.radians(work_angle_deg))


def with_travel_angle(path: WeldPath, travel_angle_deg: float) -> WeldPath:
    """Tilt the torch about the axis across the seam (local x); positions unchanged.

    Positive = push: the torch axis z leans forward, toward the travel direction (z gains +y),
    i.e. a rotation of -travel_angle about local x. Negative = drag.
    """
    return _tilted(path, 0, -np.radians(travel_angle_deg))


def _deviations(positions_m: np.ndarray, rotations: np.ndarray, first: int, last: int) -> tuple:
    """Distance (m) to the chord and angle (rad) to the slerped orientation of poses first+1 .. last-1."""
    inner = positions_m[first + 1 : last]
    chord = positions_m[last] - positions_m[first]
    chord_length = np.linalg.norm(chord)
    offsets = inner - positions_m[first]
    if chord_length == 0.0:
        distances = np.linalg.norm(offsets, axis=1)
        fractions = np.linspace(0.0, 1.0, last - first + 1)[1:-1]
    else:
        direction = chord / chord_length
        along = offsets @ direction
        distances = np.linalg.norm(offsets - along[:, None] * direction, axis=1)
        fractions = np.clip(along / chord_length, 0.0, 1.0)
    ends = Rotation.from_matrix(rotations[[first, last]])
    expected = Slerp([0.0, 1.0], ends)(fractions)
    angles = (expected.inv() * Rotation.from_matrix(rotations[first + 1 : last])).magnitude()
    return distances, angles


def decimated(path: WeldPath, tolerance_m: float, angle_tolerance_deg: float = 1.0) -> WeldPath:
    """Ramer-Douglas-Peucker on position and orientation, both ends always kept.

    Every dropped pose stays within tolerance_m of the chord between its kept neighbours and within
    angle_tolerance_deg of the orientation slerped along that chord. A closed seam is returned as an
    explicitly closed poly-line (the last pose equals the first) with closed=False.
    """
    positions_m, rotations = path.positions_m, path.rotations
    if path.closed:
        positions_m = np.concatenate([positions_m, positions_m[:1]])
        rotations = np.concatenate([rotations, rotations[:1]])
    angle_tolerance_rad = np.radians(angle_tolerance_deg)
    keep = np.zeros(len(positions_m), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(positions_m) - 1)]
    while stack:
        first, last = stack.pop()
        if last - first < 2:
            continue
        distances, angles = _deviations(positions_m, rotations, first, last)
        excess = np.maximum(distances / tolerance_m, angles / angle_tolerance_rad)
        worst = int(np.argmax(excess))
        if excess[worst] > 1.0:
            split = first + 1 + worst
            keep[split] = True
            stack += [(first, split), (split, last)]
    return replace(path, positions_m=positions_m[keep], rotations=rotations[keep], closed=False)


def backed_off(pose_matrix: np.ndarray, distance_m: float) -> np.ndarray:
    """A (4, 4) TCP pose moved distance_m back along its torch axis (-z), same orientation."""
    moved = pose_matrix.copy()
    moved[:3, 3] -= distance_m * pose_matrix[:3, 2]
    return moved


def blend_radii(positions_m: np.ndarray, max_blend_m: float) -> np.ndarray:
    """(K,) blends: min(max_blend_m, half the shorter adjacent segment - 10 um), at least 0; the first and last 0.

    The 10 um margin keeps two neighbouring blends apart even after ur-rtde writes them into its
    script with 6 significant digits (positions move by up to 0.5 um, so exact halves could overlap).
    """
    segments_m = np.linalg.norm(np.diff(positions_m, axis=0), axis=1)
    radii = np.zeros(len(positions_m))
    if len(positions_m) > 2:
        half_m = 0.5 * np.minimum(segments_m[:-1], segments_m[1:]) - BLEND_MARGIN_M
        radii[1:-1] = np.clip(half_m, 0.0, max_blend_m)
    return radii
