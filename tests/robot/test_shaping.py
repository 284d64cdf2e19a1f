from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.robot import shaping
from weldseam.types import WeldPath

# Tool frame: y = travel (+X world), z = torch axis into the work (-Z world), x = y cross z.
DOWN = np.column_stack([np.cross([1.0, 0, 0], [0, 0, -1.0]), [1.0, 0, 0], [0, 0, -1.0]])


def line_path(count: int = 201, length_m: float = 0.2) -> WeldPath:
    positions = np.column_stack([np.linspace(0.0, length_m, count), np.zeros(count), np.zeros(count)])
    return WeldPath(seam_id=0, positions_m=positions, rotations=np.tile(DOWN, (count, 1, 1)))


def arc_path(radius_m: float = 0.05, count: int = 2001) -> WeldPath:
    angles = np.linspace(0.0, np.pi, count)
    positions = radius_m * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(count)])
    return WeldPath(seam_id=1, positions_m=positions, rotations=np.tile(DOWN, (count, 1, 1)))


def chord_distances(dense: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """Distance of every dense point to the nearest segment of the kept poly-line."""
    starts, ends = kept[:-1], kept[1:]
    directions = ends - starts
    fractions = np.einsum("psk,sk->ps", dense[:, None] - starts, directions) / np.einsum(
        "sk,sk->s", directions, directions
    )
    nearest = starts + np.clip(fractions, 0, 1)[..., None] * directions
    return np.linalg.norm(dense[:, None] - nearest, axis=2).min(axis=1)


def test_standoff_moves_tcp_back_along_torch_axis():
    path = line_path(5)
    moved = shaping.with_standoff(path, 0.015)
    np.testing.assert_allclose(moved.positions_m - path.positions_m, np.tile([0, 0, 0.015], (5, 1)), atol=1e-15)
    np.testing.assert_array_equal(moved.rotations, path.rotations)


def test_work_angle_tilts_z_about_travel_and_keeps_tip_on_seam():
    path = line_path(5)
    tilted = shaping.with_work_angle(path, 10.0)
    z_old, z_new = path.rotations[:, :, 2], tilted.rotations[:, :, 2]
    angles = np.degrees(np.arccos(np.clip(np.einsum("ki,ki->k", z_old, z_new), -1, 1)))
    np.testing.assert_allclose(angles, 10.0, atol=1e-9)
    np.testing.assert_allclose(tilted.rotations[:, :, 1], path.rotations[:, :, 1], atol=1e-15)
    np.testing.assert_array_equal(tilted.positions_m, path.positions_m)
    # The tip (TCP + standoff along the new z) is still the seam point.
    backed = shaping.with_standoff(tilted, 0.012)
    np.testing.assert_allclose(backed.positions_m + 0.012 * backed.rotations[:, :, 2], path.positions_m, atol=1e-15)


def test_positive_travel_angle_pushes_torch_toward_travel():
    tilted = shaping.with_travel_angle(line_path(3), 15.0)
    z_new, travel = tilted.rotations[:, :, 2], np.array([1.0, 0, 0])
    np.testing.assert_allclose(z_new @ travel, np.sin(np.radians(15.0)), atol=1e-12)
    np.testing.assert_allclose(tilted.rotations[:, :, 0], line_path(3).rotations[:, :, 0], atol=1e-15)


def test_decimating_a_straight_line_keeps_two_poses():
    kept = shaping.decimated(line_path(), 0.0002)
    np.testing.assert_array_equal(kept.positions_m, line_path().positions_m[[0, -1]])


def test_decimating_an_arc_keeps_every_chord_within_tolerance():
    path = arc_path()
    kept = shaping.decimated(path, 0.0002)
    assert 4 < len(kept.positions_m) < len(path.positions_m) / 10
    assert chord_distances(path.positions_m, kept.positions_m).max() <= 0.0002 + 1e-12
    np.testing.assert_array_equal(kept.positions_m[[0, -1]], path.positions_m[[0, -1]])


def test_decimation_keeps_orientation_changes():
    path = line_path(101)
    twist = Rotation.from_euler("z", np.r_[np.zeros(50), np.linspace(0, 30, 51)][:, None], degrees=True).as_matrix()
    path = WeldPath(seam_id=0, positions_m=path.positions_m, rotations=path.rotations @ twist)
    kept = shaping.decimated(path, 0.0002, angle_tolerance_deg=1.0)
    assert len(kept.positions_m) > 2
    assert any(np.allclose(p, path.positions_m[50]) for p in kept.positions_m)


def test_closed_seam_stays_closed():
    angles = np.linspace(0.0, 2 * np.pi, 400, endpoint=False)
    positions = 0.05 * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(400)])
    loop = WeldPath(seam_id=2, positions_m=positions, rotations=np.tile(DOWN, (400, 1, 1)), closed=True)
    kept = shaping.decimated(loop, 0.0002)
    np.testing.assert_array_equal(kept.positions_m[0], kept.positions_m[-1])
    np.testing.assert_array_equal(kept.positions_m[0], positions[0])
    assert chord_distances(np.vstack([positions, positions[:1]]), kept.positions_m).max() <= 0.0002 + 1e-12


@pytest.mark.parametrize(
    "modifier",
    [
        lambda p: shaping.decimated(p, 0.0002),
        lambda p: shaping.with_work_angle(p, 0.0),
        lambda p: shaping.to_robot_base(p, np.eye(4)),
    ],
)
def test_idempotent_modifiers(modifier):
    once = modifier(arc_path(count=501))
    twice = modifier(once)
    np.testing.assert_array_equal(twice.positions_m, once.positions_m)
    np.testing.assert_array_equal(twice.rotations, once.rotations)


def test_robot_base_transforms_positions_and_frames():
    base = np.eye(4)
    base[:3, :3] = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    base[:3, 3] = [0.4, -0.1, 0.05]
    moved = shaping.to_robot_base(line_path(3), base)
    np.testing.assert_allclose(moved.positions_m[-1], [0.4, 0.1, 0.05], atol=1e-12)
    np.testing.assert_allclose(moved.rotations[:, :, 1], np.tile([0, 1.0, 0], (3, 1)), atol=1e-12)


def test_backed_off_pose_moves_along_minus_z():
    pose = np.eye(4)
    pose[:3, :3] = DOWN
    pose[:3, 3] = [0.3, 0.2, 0.1]
    np.testing.assert_allclose(shaping.backed_off(pose, 0.05)[:3, 3], [0.3, 0.2, 0.15], atol=1e-15)


def test_blends_never_exceed_half_the_shorter_segment_and_ends_are_zero():
    positions = np.cumsum(np.column_stack([[0, 0.01, 0.002, 0.03, 0.004, 0.02], np.zeros(6), np.zeros(6)]), axis=0)
    radii = shaping.blend_radii(positions, 0.005)
    segments = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    assert radii[0] == 0.0 and radii[-1] == 0.0
    assert np.all(radii[1:-1] <= 0.5 * np.minimum(segments[:-1], segments[1:]) - shaping.BLEND_MARGIN_M + 1e-15)
    assert np.all(radii <= 0.005)
    np.testing.assert_allclose(radii[1:-1], np.array([0.001, 0.001, 0.002, 0.002]) - 1e-5)
    assert np.all(shaping.blend_radii(positions * 1e-3, 0.005) == 0.0), "segments under 20 um get no blend"
