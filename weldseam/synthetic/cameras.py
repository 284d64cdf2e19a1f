"""Camera placements anywhere in the cone that sees the seam.

`scenes.default_camera` is the narrow placement the acceptance tests and golden files use:
within 10-30 deg of each family's chosen view axis, 0.35-0.6 m away, image up = base z.
`broad_camera` draws from the cone a welding cell meets: tilt 0-45 deg from the view axis,
any azimuth, any roll about the optical axis, 0.3-0.7 m, aim point up to 25 mm off the
target; it keeps a placement only when `seam_in_view` says the seam is seen from it.

Units: metres and degrees (parameters), base frame z up.
"""

from __future__ import annotations

import numpy as np

from weldseam.geometry import unit
from weldseam.synthetic.scenes import UP, SyntheticScene, visible_mask
from weldseam.synthetic.sensor import D415, look_at
from weldseam.types import Intrinsics

REFERENCE_DISTANCE_M = 0.5


def visible_lengths_m(scene: SyntheticScene, T_base_camera: np.ndarray,
                      intrinsics: Intrinsics = D415) -> np.ndarray:
    """(S,) length (m) of each truth seam between consecutive points the camera sees
    (closing segment included for closed seams)."""
    lengths = []
    for seam in scene.seams:
        seen = visible_mask(scene, seam, T_base_camera, intrinsics)
        steps = np.linalg.norm(np.diff(seam.points_m, axis=0), axis=1)
        both = seen[:-1] & seen[1:]
        closing = np.linalg.norm(seam.points_m[0] - seam.points_m[-1]) if seam.closed else 0.0
        lengths.append(steps[both].sum() + (closing if seen[0] and seen[-1] else 0.0))
    return np.array(lengths, dtype=float)


def reference_lengths_m(scene: SyntheticScene, intrinsics: Intrinsics = D415) -> np.ndarray:
    """(S,) seam lengths (m) seen by the reference camera: on the view axis,
    REFERENCE_DISTANCE_M from the target."""
    target = np.asarray(scene.camera_target_m, float)
    eye = target + REFERENCE_DISTANCE_M * unit(np.asarray(scene.view_axis_m, float))
    return visible_lengths_m(scene, look_at(eye, target), intrinsics)


def seam_in_view(
    scene: SyntheticScene, T_base_camera: np.ndarray, reference_m: np.ndarray,
    intrinsics: Intrinsics = D415, *, min_fraction: float = 0.5, min_length_m: float = 0.02,
    min_elevation_deg: float = 15.0,
) -> bool:
    """True when the camera is at least `min_elevation_deg` above the horizontal through the
    target and sees, of every seam the reference camera sees over `min_length_m` or more
    (`reference_m`, from `reference_lengths_m`), at least `min_fraction` of that length and
    at least `min_length_m`. A scene without seams is in view from any such height."""
    offset = T_base_camera[:3, 3] - np.asarray(scene.camera_target_m, float)
    if offset @ UP < np.sin(np.radians(min_elevation_deg)) * np.linalg.norm(offset):
        return False
    expected = reference_m >= min_length_m
    if not expected.any():
        return True
    seen = visible_lengths_m(scene, T_base_camera, intrinsics)[expected]
    return bool(np.all(seen >= np.maximum(min_fraction * reference_m[expected], min_length_m)))


def broad_camera(
    scene: SyntheticScene, rng: np.random.Generator, intrinsics: Intrinsics = D415, *,
    max_tilt_deg: float = 45.0, distance_m: tuple[float, float] = (0.3, 0.7),
    max_aim_offset_m: float = 0.025, attempts: int = 200,
) -> np.ndarray:
    """(4, 4) T_base_camera drawn until the seam is in view: direction tilted from
    scene.view_axis_m by a uniform 0..max_tilt_deg toward a uniform azimuth, distance uniform
    in `distance_m`, aim point uniform in a disc of radius max_aim_offset_m around the target
    (perpendicular to the view), roll uniform. Raises ValueError after `attempts` draws."""
    axis = unit(np.asarray(scene.view_axis_m, float))
    first = unit(np.cross(axis, UP if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])))
    second = np.cross(axis, first)
    reference = reference_lengths_m(scene, intrinsics)
    for _ in range(attempts):
        tilt = np.radians(rng.uniform(0.0, max_tilt_deg))
        azimuth, roll, aim_angle = rng.uniform(0.0, 2 * np.pi, 3)
        distance = rng.uniform(*distance_m)
        aim_radius = max_aim_offset_m * np.sqrt(rng.uniform())
        direction = np.cos(tilt) * axis + np.sin(tilt) * (
            np.cos(azimuth) * first + np.sin(azimuth) * second
        )
        across = unit(np.cross(direction, first if abs(direction @ first) < 0.9 else second))
        sideways = np.cross(direction, across)
        target = np.asarray(scene.camera_target_m, float) + aim_radius * (
            np.cos(aim_angle) * across + np.sin(aim_angle) * sideways
        )
        up = np.cos(roll) * across + np.sin(roll) * sideways
        pose = look_at(target + distance * direction, target, up)
        if seam_in_view(scene, pose, reference, intrinsics):
            return pose
    raise ValueError(f"{scene.name}: no camera in the cone sees the seam after {attempts} draws")
