"""Plate joint families: each truth point where its definition puts it, on the rendered
geometry, with the torch axis its joint's rule gives."""

import numpy as np
import pytest

from tests.synthetic.checks import (
    distance_to_mesh, opening_edges, polyline_projection, seam_frame,
)
from weldseam.geometry import unit
from weldseam.synthetic.joints import (
    bevel, clutter, lap, lap_and_fillet, outside_corner, square_butt, tacked, v_groove_and_square_butt,
)
from weldseam.synthetic.scenes import UP, make_scan
from weldseam.synthetic.sensor import cast_rays

SEEDS = range(4)


def _interior(seam, count=5):
    """Indices of `count` truth points spread over the middle 60 % of a seam."""
    return np.linspace(0.2, 0.8, count).astype(float) * (len(seam.points_m) - 1)


@pytest.mark.parametrize("family", [bevel, square_butt, outside_corner])
@pytest.mark.parametrize("seed", SEEDS)
def test_groove_truth_is_the_middle_of_the_opening_at_the_surface(family, seed):
    scene = family(np.random.default_rng(seed))
    (seam,) = scene.seams
    for index in _interior(seam).astype(int):
        point, axis = seam.points_m[index], seam.torch_axes[index]
        _, across = seam_frame(seam, index)
        (left, right), slopes = opening_edges(scene.mesh, point, axis, across)
        assert np.linalg.norm((left + right) / 2 - point) < 4e-5
        assert np.linalg.norm(right - left) > 0.0007
        # The torch axis is minus the bisector of the two outer faces' normals: their
        # slopes along it are equal and opposite (0 for plates, -1 and +1 for the corner).
        assert slopes[0] == pytest.approx(-slopes[1], abs=1e-3)
        if family is outside_corner:
            assert abs(slopes[0]) == pytest.approx(1.0, abs=2e-3)  # faces at 45 deg to it
        else:
            assert slopes[0] == pytest.approx(0.0, abs=1e-3)  # perpendicular to the plates


@pytest.mark.parametrize("seed", SEEDS)
def test_v_groove_and_square_butt_truth_is_each_openings_middle_with_its_own_kind(seed):
    scene = v_groove_and_square_butt(np.random.default_rng(seed))
    assert [seam.joint for seam in scene.seams] == ["v_groove", "square_butt"]
    widths = []
    for seam in scene.seams:
        for index in _interior(seam).astype(int):
            point, axis = seam.points_m[index], seam.torch_axes[index]
            _, across = seam_frame(seam, index)
            (left, right), slopes = opening_edges(scene.mesh, point, axis, across)
            assert np.linalg.norm((left + right) / 2 - point) < 4e-5
            assert slopes[0] == pytest.approx(0.0, abs=1e-3) and slopes[1] == pytest.approx(0.0, abs=1e-3)
            widths.append((seam.joint, np.linalg.norm(right - left)))
    butt = [width for joint, width in widths if joint == "square_butt"]
    assert 0.0008 - 1e-5 <= min(butt) and max(butt) <= 0.003 + 1e-5, "the square gap, no bevel"
    assert min(width for joint, width in widths if joint == "v_groove") > max(butt), "the V opens wider"


def test_bevel_has_one_square_edge_and_one_bevelled_edge():
    rng = np.random.default_rng(3)
    scene = bevel(rng, bevel_angle_deg=40.0, root_gap_m=0.001, root_face_m=0.001,
                  thickness_m=0.010, mount="table", yaw_deg=0.0)
    point = scene.seams[0].points_m[300]
    # Rays straight down across the opening: flat root gap between x = -0.5 and +0.5 mm,
    # the square wall at x = -0.5 mm, the bevel rising from x = 0.5 mm at 40 deg.
    offsets = np.linspace(-0.0005, 0.0005 + 0.009 * np.tan(np.radians(40)), 200)[1:-1]
    origins = np.column_stack([offsets, np.full_like(offsets, point[1]), np.full_like(offsets, 0.02)])
    t_hit, _ = cast_rays(scene.mesh, origins, np.broadcast_to(-UP, origins.shape))
    surface = 0.02 - t_hit
    on_bevel = offsets > 0.0005
    expected = 0.001 + (offsets[on_bevel] - 0.0005) / np.tan(np.radians(40))
    assert np.allclose(surface[on_bevel], expected, atol=1e-6)
    assert np.allclose(surface[~on_bevel], 0.0, atol=1e-6)  # the table through the root gap
    assert point[0] == pytest.approx((0.009 * np.tan(np.radians(40))) / 2, abs=1e-9)


@pytest.mark.parametrize("seed", SEEDS)
def test_lap_truth_is_the_inside_corner_at_the_top_plates_edge(seed):
    scene = lap(np.random.default_rng(seed))
    (seam,) = scene.seams
    assert seam.joint == "lap"
    points = seam.points_m[::40]
    axes = seam.torch_axes[::40]
    assert distance_to_mesh(scene.parts[0], points).max() < 1e-6  # on the bottom plate
    assert distance_to_mesh(scene.parts[1], points).max() < 1e-6  # on the top plate's edge
    # From 3 mm back along the torch axis the ray meets nothing before the corner.
    t_hit, _ = cast_rays(scene.mesh, points - 0.003 * axes, axes)
    assert np.allclose(t_hit, 0.003, atol=1e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_lap_and_fillet_truth_is_each_inside_corner_with_its_own_kind(seed):
    scene = lap_and_fillet(np.random.default_rng(seed))
    lap_seam, fillet_seam = scene.seams
    base, top, web = scene.parts
    assert (lap_seam.joint, fillet_seam.joint) == ("lap", "fillet")
    for seam, faces in ((lap_seam, (base, top)), (fillet_seam, (top, web))):
        points, axes = seam.points_m[::40], seam.torch_axes[::40]
        for face in faces:
            assert distance_to_mesh(face, points).max() < 1e-6
        # From 3 mm back along the torch axis the ray meets nothing before the corner.
        t_hit, _ = cast_rays(scene.mesh, points - 0.003 * axes, axes)
        assert np.allclose(t_hit, 0.003, atol=1e-6)
    # The two corners open the same way (toward +x before the scene is turned and mounted).
    assert np.dot(lap_seam.torch_axes[0], fillet_seam.torch_axes[0]) > 0.9


def test_lap_and_fillet_torch_axes_are_the_laps_split_and_the_fillets_bisector():
    scene = lap_and_fillet(np.random.default_rng(5), torch_split_deg=60.0, mount="table", yaw_deg=0.0)
    lap_axes, fillet_axes = scene.seams[0].torch_axes, scene.seams[1].torch_axes
    assert np.degrees(np.arcsin(-lap_axes[:, 2])) == pytest.approx(np.full(len(lap_axes), 60.0))
    assert lap_axes[:, 0] == pytest.approx(np.full(len(lap_axes), -0.5)), "into the corner, from its open side"
    assert fillet_axes == pytest.approx(np.tile([-np.sqrt(0.5), 0.0, -np.sqrt(0.5)], (len(fillet_axes), 1)))


@pytest.mark.parametrize("split_deg", [45.0, 60.0])
def test_lap_torch_axis_is_split_degrees_from_the_bottom_plate(split_deg):
    scene = lap(np.random.default_rng(5), torch_split_deg=split_deg, mount="table", yaw_deg=0.0)
    axes = scene.seams[0].torch_axes
    # Bottom plate normal +z; the top plate's edge face looks along -x.
    assert np.degrees(np.arcsin(-axes[:, 2])) == pytest.approx(np.full(len(axes), split_deg))
    assert np.allclose(axes[:, 1], 0.0)
    if split_deg == 45.0:
        assert np.allclose(axes, -unit(np.array([0.0, 0.0, 1.0]) + [-1.0, 0.0, 0.0]))


@pytest.mark.parametrize("seed", SEEDS)
def test_outside_corner_rests_on_both_far_edges_with_its_ridge_up(seed):
    scene = outside_corner(np.random.default_rng(seed))
    for plate in scene.parts:
        assert plate.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-9)
    axis = scene.seams[0].torch_axes[0]
    assert np.degrees(np.arccos(-axis[2])) <= 15.0 + 1e-9  # rolled by at most 15 deg


@pytest.mark.parametrize("seed", SEEDS)
def test_each_tack_lies_on_its_seam_with_its_length_and_height(seed):
    scene = tacked(np.random.default_rng(seed))
    (seam,) = scene.seams
    assert 2 <= len(seam.tacks) <= 4
    points, axes = seam.points_m, seam.torch_axes
    along = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    # Rays along the torch axis from 10 mm behind each truth point: where they stop short
    # of the surface by more than 0.1 mm, a tack stands on the seam.
    t_hit, _ = cast_rays(scene.mesh, points - 0.01 * axes, axes)
    raised = t_hit < 0.01 - 0.0001
    expected = np.zeros(len(points), dtype=bool)
    ends = np.zeros(len(points), dtype=bool)
    for tack in seam.tacks:
        off_seam, centre = polyline_projection(points, tack.centre_m)
        assert off_seam < 1e-9  # on the seam line
        assert 0.006 <= tack.length_m <= 0.012 and 0.0015 <= tack.height_m <= 0.003
        expected |= np.abs(along - centre) < tack.length_m / 2 - 0.0001
        ends |= np.abs(np.abs(along - centre) - tack.length_m / 2) <= 0.0001
        apex, _ = cast_rays(scene.mesh, tack.centre_m[None] - 0.01 * axes[:1], axes[:1])
        assert 0.01 - apex[0] == pytest.approx(tack.height_m, abs=1e-6)
    assert np.all(raised[expected]) and not np.any(raised & ~expected & ~ends)
    spans = sorted((polyline_projection(points, t.centre_m)[1] - t.length_m / 2,
                    polyline_projection(points, t.centre_m)[1] + t.length_m / 2) for t in seam.tacks)
    spans = np.array(spans)
    assert np.all(spans[1:, 0] - spans[:-1, 1] >= 0.02 - 1e-9)
    assert spans[0, 0] >= 0.015 - 1e-9 and along[-1] - spans[-1, 1] >= 0.015 - 1e-9


def test_the_seam_under_a_tack_counts_as_seen():
    rng = np.random.default_rng(2)
    scene = tacked(rng, yaw_deg=0.0)
    scan = make_scan(scene, rng)
    seam = scene.seams[0]
    for tack in seam.tacks:
        under = np.linalg.norm(seam.points_m - tack.centre_m, axis=1) < tack.length_m / 2
        assert scan.visible[0][under].all()


@pytest.mark.parametrize("seed", SEEDS)
def test_clutter_keeps_the_base_seams_and_adds_clamps_and_bars(seed):
    scene = clutter(np.random.default_rng(seed))
    assert len(scene.fixtures) >= 3  # at least one clamp (arm and post) and one bar
    touching = [f for f in scene.fixtures
                if min(distance_to_mesh(p, f.vertices).min() for p in scene.parts) < 1e-6]
    assert touching  # a clamp's arm lies on a plate
    for seam in scene.seams:
        assert seam.joint in ("v_groove", "lap", "fillet")
