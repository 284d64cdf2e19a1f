"""The broad camera: anywhere in the 45-degree cone around the seam's view axis, 0.3-0.7 m
away, any roll, and only where the seam is in view."""

import numpy as np
import pytest

from weldseam.geometry import unit
from weldseam.synthetic.cameras import (
    broad_camera, reference_lengths_m, seam_in_view, visible_lengths_m,
)
from weldseam.synthetic.catalog import ALL_FAMILIES
from weldseam.synthetic.scenes import fillet_t, v_butt, visible_mask
from weldseam.synthetic.sensor import look_at


@pytest.mark.parametrize("family", sorted(ALL_FAMILIES))
def test_every_drawn_camera_sees_the_seam_from_inside_the_cone(family):
    rng = np.random.default_rng(40)
    scene = ALL_FAMILIES[family](rng)
    reference = reference_lengths_m(scene)
    axis = unit(scene.view_axis_m)
    for _ in range(3):
        pose = broad_camera(scene, rng)
        eye = pose[:3, 3]
        offset = eye - scene.camera_target_m
        assert 0.3 - 0.026 <= np.linalg.norm(offset) <= 0.7 + 0.026
        assert np.degrees(np.arccos(unit(offset) @ axis)) <= 45.0 + 5.0  # aim offset <= 25 mm
        # The optical axis passes within 25 mm of the target.
        along = (scene.camera_target_m - eye) @ pose[:3, 2]
        miss = np.linalg.norm(scene.camera_target_m - eye - along * pose[:3, 2])
        assert miss <= 0.025 + 1e-9
        assert np.allclose(pose[:3, :3].T @ pose[:3, :3], np.eye(3))
        seen = visible_lengths_m(scene, pose)
        for length, expected in zip(seen, reference):
            if expected >= 0.02:
                assert length >= max(0.5 * expected, 0.02)
        assert offset[2] >= np.sin(np.radians(15.0)) * np.linalg.norm(offset)


def test_the_cone_is_broad_tilt_distance_and_roll():
    rng = np.random.default_rng(41)
    scene = v_butt(rng, yaw_deg=0.0)
    poses = [broad_camera(scene, rng, max_aim_offset_m=0.0) for _ in range(60)]
    offsets = np.array([p[:3, 3] - scene.camera_target_m for p in poses])
    tilts = np.degrees(np.arccos(unit(offsets) @ scene.view_axis_m))
    distances = np.linalg.norm(offsets, axis=1)
    rolls = np.degrees(np.arctan2(*np.array([p[:2, 0] for p in poses]).T))
    assert tilts.min() < 8.0 and tilts.max() > 38.0 and tilts.max() <= 45.0 + 1e-9
    assert distances.min() < 0.36 and distances.max() > 0.64
    assert np.ptp(rolls) > 300.0  # image x points every way
    azimuths = np.degrees(np.arctan2(offsets[:, 1], offsets[:, 0]))
    assert np.ptp(azimuths) > 300.0


def test_seam_in_view_rejects_a_camera_that_cannot_see_it():
    rng = np.random.default_rng(42)
    scene = fillet_t(rng, side=1.0, yaw_deg=0.0)
    reference = reference_lengths_m(scene)
    target = scene.camera_target_m
    near_side = look_at(target + 0.45 * scene.view_axis_m, target)
    far_side = look_at(target + 0.45 * unit([0.0, -0.6, 0.8]), target)  # the web hides it
    low = look_at(target + 0.45 * unit([1.0, 0.0, 0.1]), target)  # 6 deg above the table
    assert seam_in_view(scene, near_side, reference)
    assert not seam_in_view(scene, far_side, reference)
    assert not seam_in_view(scene, low, reference)
    seam = scene.seams[int(np.argmax(reference))]
    assert not visible_mask(scene, seam, far_side).any()


def test_broad_camera_gives_up_with_a_message_when_nothing_sees_the_seam():
    rng = np.random.default_rng(43)
    scene = v_butt(rng)
    with pytest.raises(ValueError, match="no camera in the cone sees the seam"):
        broad_camera(scene, rng, distance_m=(0.01, 0.01), attempts=3)  # 1 cm: sees 1 cm of it
