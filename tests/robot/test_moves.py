from __future__ import annotations

import numpy as np

from weldseam.robot.motion import pose_matrices
from weldseam.robot.moves import Shaping, estimated_time_s, motion_plan
from weldseam.types import WeldPath

DOWN = np.column_stack([np.cross([1.0, 0, 0], [0, 0, -1.0]), [1.0, 0, 0], [0, 0, -1.0]])


def line(seam_id: int, y_m: float, count: int = 101) -> WeldPath:
    positions = np.column_stack([np.linspace(0.0, 0.1, count), np.full(count, y_m), np.zeros(count)])
    return WeldPath(seam_id=seam_id, positions_m=positions, rotations=np.tile(DOWN, (count, 1, 1)))


def test_plan_applies_base_standoff_and_approach():
    setup = Shaping(base_pose=(0.4, 0.0, 0.1, 0, 0, 0), standoff_m=0.015, approach_m=0.05, arc_output=3)
    plan = motion_plan([line(0, 0.0), line(1, 0.05)], setup)
    assert [seam.seam_id for seam in plan.seams] == [0, 1]
    first = plan.seams[0]
    np.testing.assert_allclose(first.weld_poses[:, :3], [[0.4, 0.0, 0.115], [0.5, 0.0, 0.115]], atol=1e-12)
    np.testing.assert_allclose(first.approach_pose[:3], [0.4, 0.0, 0.165], atol=1e-12)
    np.testing.assert_allclose(first.retreat_pose[:3], [0.5, 0.0, 0.165], atol=1e-12)
    np.testing.assert_allclose(pose_matrices(first.weld_poses)[:, :3, :3], np.tile(DOWN, (2, 1, 1)), atol=1e-12)
    np.testing.assert_array_equal(first.blend_radii_m, [0.0, 0.0])
    assert plan.arc_output == 3
    assert abs(plan.weld_length_m - 0.2) < 1e-12


def test_time_estimate_counts_weld_and_moves():
    setup = Shaping(approach_m=0.05, weld_speed_m_s=0.01, move_speed_m_s=0.1)
    plan = motion_plan([line(0, 0.0), line(1, 0.05)], setup)
    # weld 0.2 m at 10 mm/s; moves: 4 x 0.05 m approach/retreat + the travel (0.1, 0) -> (0, 0.05) between seams
    travel_m = np.hypot(0.1, 0.05)
    assert abs(estimated_time_s(plan) - (20.0 + (0.2 + travel_m) / 0.1)) < 1e-9
