"""The work angle turns the torch to a side set by the joint kind, the same whichever way a seam is welded."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.errors import InputError
from weldseam.pipeline.joints.base import JointKind
from weldseam.robot import shaping
from weldseam.robot.moves import Shaping, shaped_path
from weldseam.robot.work_angle import LADDERS, work_angle_rule
from weldseam.types import JOINT_KINDS, WeldPath

UP = np.array([0.0, 0.0, 1.0])


def seam(joint: str | None, start, end, torch_axis, count: int = 21) -> WeldPath:
    """A straight seam from start to end (robot base frame, m), one torch axis into the work."""
    positions = np.linspace(start, end, count)
    travel = np.asarray(end, float) - np.asarray(start, float)
    travel /= np.linalg.norm(travel)
    z = np.asarray(torch_axis, float) / np.linalg.norm(torch_axis)
    frame = np.column_stack([np.cross(travel, z), travel, z])
    return WeldPath(0, positions, np.tile(frame, (count, 1, 1)), joint=joint)


def reversed_seam(path: WeldPath) -> WeldPath:
    """The same seam welded the other way: poses reversed, travel (y) and across (x) flipped."""
    flip = np.diag([-1.0, -1.0, 1.0])
    return WeldPath(path.seam_id, path.positions_m[::-1], path.rotations[::-1] @ flip, joint=path.joint)


def tilted_axes(path: WeldPath, work_angle_deg: float) -> np.ndarray:
    """(K, 3) torch axes after the kind's work-angle rule."""
    rule = work_angle_rule(path, work_angle_deg)
    return shaping.with_work_angle(path, rule.rotation_deg).rotations[:, :, 2]


def angle_from_plane_deg(axes: np.ndarray, normal) -> np.ndarray:
    """(K,) angle between each torch axis and the plane of unit `normal`, degrees."""
    return np.degrees(np.arcsin(np.abs(axes @ np.asarray(normal, float))))


def yawed(vector, yaw_deg: float) -> np.ndarray:
    return Rotation.from_euler("z", yaw_deg, degrees=True).apply(np.asarray(vector, float))


@pytest.mark.parametrize("yaw_deg", [0.0, 37.0, 90.0, 200.0, 300.0])
def test_a_fillet_welded_either_way_tilts_toward_the_bottom_plate_by_the_same_angle(yaw_deg):
    # A wall on the bottom plate (z = 0), its face toward +y (before the yaw); the corner runs along x.
    start, end = yawed([0.35, -0.1, 0.0], yaw_deg), yawed([0.55, -0.1, 0.0], yaw_deg)
    wall_normal = yawed([0.0, 1.0, 0.0], yaw_deg)
    bisector = -(wall_normal + UP) / np.sqrt(2.0)
    forward = seam("fillet", start, end, bisector)
    for path in (forward, reversed_seam(forward)):
        axes = tilted_axes(path, 10.0)
        np.testing.assert_allclose(angle_from_plane_deg(axes, UP), 55.0, atol=1e-9)
        np.testing.assert_allclose(angle_from_plane_deg(axes, wall_normal), 35.0, atol=1e-9)
        np.testing.assert_allclose(axes, tilted_axes(forward, 10.0)[::-1], atol=1e-12)
        assert work_angle_rule(path, 10.0).side == "lower_face"


@pytest.mark.parametrize("split_deg, work_angle_deg", [(45.0, 15.0), (60.0, -10.0), (45.0, 0.0)])
def test_a_laps_work_angle_adds_to_its_split_from_the_bottom_plate(split_deg, work_angle_deg):
    # The lap model's axis: -(cos(split) e + sin(split) n), e the top plate's edge-face normal.
    edge_normal, split = np.array([0.0, 1.0, 0.0]), np.radians(split_deg)
    axis = -(np.cos(split) * edge_normal + np.sin(split) * UP)
    forward = seam("lap", [-0.1, 0.4, 0.0], [0.1, 0.4, 0.0], axis)
    for path in (forward, reversed_seam(forward)):
        axes = tilted_axes(path, work_angle_deg)
        np.testing.assert_allclose(angle_from_plane_deg(axes, UP), split_deg + work_angle_deg, atol=1e-9)
        assert np.all(axes @ edge_normal < 0), "still aimed into the corner, toward the top plate's edge"
    assert "added to the plan's split" in work_angle_rule(forward, work_angle_deg).text()


@pytest.mark.parametrize("joint", ["v_groove", "bevel", "square_butt"])
def test_a_groove_square_to_the_robot_tilts_toward_the_plate_farther_from_it_either_way(joint):
    # The seam runs along y at x = 0.45 in front of the robot: the plate on +x is the farther one.
    forward = seam(joint, [0.45, -0.1, 0.0], [0.45, 0.1, 0.0], -UP)
    for path in (forward, reversed_seam(forward)):
        axes = tilted_axes(path, 8.0)
        np.testing.assert_allclose(axes @ [1.0, 0.0, 0.0], np.sin(np.radians(8.0)), atol=1e-12)
        rule = work_angle_rule(path, 8.0)
        assert (rule.side, rule.fallback) == ("away_from_robot", False)


def test_a_groove_running_toward_the_robot_tilts_to_the_robots_left_either_way():
    forward = seam("v_groove", [0.3, 0.2, 0.0], [0.6, 0.4, 0.0], -UP)  # along the line from the base
    left = np.cross(UP, [0.6, 0.4, 0.0]) / np.hypot(0.6, 0.4)
    for path in (forward, reversed_seam(forward)):
        axes = tilted_axes(path, 8.0)
        np.testing.assert_allclose(axes @ left, np.sin(np.radians(8.0)), atol=1e-9)
        rule = work_angle_rule(path, 8.0)
        assert rule.side == "robot_left" and "(the seam runs square to it)" in rule.text()


def test_a_vertical_fillet_has_level_faces_and_tilts_toward_the_wall_farther_from_the_robot():
    # The inside corner of a box standing at x = 0.5, y = 0: walls facing -x and +y; the seam runs up.
    faces = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    bisector = -faces.sum(axis=0) / np.sqrt(2.0)
    forward = seam("fillet", [0.5, 0.0, 0.0], [0.5, 0.0, 0.2], bisector)
    for path in (forward, reversed_seam(forward)):
        rule = work_angle_rule(path, 10.0)
        assert rule.side == "away_from_robot" and "(its faces stand level)" in rule.text()
        axes = tilted_axes(path, 10.0)
        # Toward the wall facing -x (the farther one): a steeper angle to it, 55 deg, 35 to the other.
        np.testing.assert_allclose(angle_from_plane_deg(axes, faces[0]), 55.0, atol=1e-9)
        np.testing.assert_allclose(angle_from_plane_deg(axes, faces[1]), 35.0, atol=1e-9)


@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_a_flat_ring_groove_tilts_toward_its_inside_whichever_way_it_turns(sense):
    angles = sense * np.linspace(0.0, 2 * np.pi, 72, endpoint=False)
    centre = np.array([0.5, 0.1, 0.0])
    radial = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(72)])
    travel = sense * np.column_stack([-np.sin(angles), np.cos(angles), np.zeros(72)])
    down = np.tile(-UP, (72, 1))
    ring = WeldPath(3, centre + 0.03 * radial, np.stack([np.cross(travel, down), travel, down], axis=2),
                    closed=True, joint="v_groove")  # fmt: skip
    assert work_angle_rule(ring, 6.0).side == "inside"
    axes = tilted_axes(ring, 6.0)
    np.testing.assert_allclose(np.sum(axes * -radial, axis=1), np.sin(np.radians(6.0)), atol=1e-12)


def test_every_joint_kind_has_a_rule_and_the_kinds_are_the_pipelines():
    assert set(JOINT_KINDS) == {kind.value for kind in JointKind} == set(LADDERS)


def test_a_work_angle_on_a_seam_of_unknown_kind_is_refused_and_none_passes():
    unknown = seam(None, [0.45, -0.1, 0.0], [0.45, 0.1, 0.0], -UP)
    with pytest.raises(InputError, match="seam 0: its joint kind is unknown"):
        shaped_path(unknown, Shaping(work_angle_deg=5.0))
    shaped, rule = shaped_path(unknown, Shaping())
    assert rule.side is None and rule.text() == "seam 0: unknown joint kind, no work angle"
    np.testing.assert_array_equal(shaped.rotations[0], unknown.rotations[0])


def test_a_zero_work_angle_leaves_the_torch_as_planned():
    path = seam("fillet", [0.35, -0.1, 0.0], [0.55, -0.1, 0.0], [0.0, -1.0, -1.0])
    shaped, rule = shaped_path(path, Shaping())
    assert rule.side == "lower_face" and rule.rotation_deg == 0.0
    np.testing.assert_array_equal(shaped.rotations[0], path.rotations[0])


@pytest.fixture(scope="module")
def lap_beside_fillet():
    """The planned paths of a lap beside a fillet lying flat on the table, in the scan's base frame (z up)."""
    from weldseam.config import PlanConfig
    from weldseam.pipeline.run import plan_paths
    from weldseam.synthetic.joints import lap_and_fillet
    from weldseam.synthetic.scenes import default_camera, make_scan
    from weldseam.types import Scan

    rng = np.random.default_rng(7)
    scene = lap_and_fillet(rng, mount="table")
    scan = make_scan(scene, rng, T_base_camera=default_camera(scene, rng))
    paths = plan_paths(Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m), PlanConfig()).paths
    return {path.joint: path for path in paths}


def test_a_planned_lap_and_fillet_each_tilt_toward_their_bottom_plate(lap_beside_fillet):
    assert sorted(lap_beside_fillet) == ["fillet", "lap"]
    for joint, path in lap_beside_fillet.items():
        planned_deg = angle_from_plane_deg(path.rotations[:, :, 2], UP)  # both bottom plates lie flat
        assert abs(np.median(planned_deg) - 45.0) < 3.0, f"{joint}: the lap's split and the fillet's bisector"
        forward = tilted_axes(path, 12.0)
        np.testing.assert_allclose(angle_from_plane_deg(forward, UP), planned_deg + 12.0, atol=0.5, err_msg=joint)
        np.testing.assert_allclose(tilted_axes(reversed_seam(path), 12.0), forward[::-1], atol=1e-12)
        assert work_angle_rule(path, 12.0).side == work_angle_rule(reversed_seam(path), 12.0).side == "lower_face"
