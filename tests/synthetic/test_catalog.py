"""The family catalogue and draw_case: today's distribution unchanged, the broad one
deterministic, every new family rendered with its seam in view."""

import numpy as np
import pytest

from weldseam.synthetic.catalog import ALL_FAMILIES, GROUPS, NEW_FAMILIES, draw_case
from weldseam.synthetic.scenes import FAMILIES, make_scan

JOINTS = {"v_groove", "bevel", "square_butt", "fillet", "lap", "outside_corner"}


@pytest.mark.parametrize("family", ["v_butt", "fillet_t", "pipe_groove"])
def test_the_default_draw_is_todays_scan_byte_for_byte(family):
    rng = np.random.default_rng(3)
    expected = make_scan(FAMILIES[family](rng), rng)
    _, scan = draw_case(family, 3)
    assert np.array_equal(scan.depth, expected.depth)
    assert np.array_equal(scan.T_base_camera, expected.T_base_camera)


def test_the_broad_draw_is_deterministic_and_differs_from_the_default():
    first_scene, first = draw_case("fillet_t", 5, broad=True)
    _, again = draw_case("fillet_t", 5, broad=True)
    _, narrow = draw_case("fillet_t", 5)
    assert np.array_equal(first.depth, again.depth)
    assert all(np.array_equal(a, b) for a, b in zip(first.visible, again.visible))
    assert not np.array_equal(first.depth, narrow.depth)
    assert len(first_scene.fixtures) >= len(draw_case("fillet_t", 5)[0].fixtures)


@pytest.mark.parametrize("family", sorted(NEW_FAMILIES))
def test_new_family_builds_renders_and_shows_its_seams(family):
    scene, scan = draw_case(family, 7, broad=True)
    assert all(part.is_volume for part in scene.parts)
    assert all(fixture.is_volume for fixture in scene.fixtures)
    assert len(scan.points_m) > 50_000
    for seam in scene.seams:
        assert seam.joint in JOINTS
        assert seam.points_m.shape == seam.torch_axes.shape
        assert np.allclose(np.linalg.norm(seam.torch_axes, axis=1), 1.0)
        steps = np.linalg.norm(np.diff(seam.points_m, axis=0), axis=1)
        assert steps.max() <= 0.00051
    seen = [v[:-1] & v[1:] for v in scan.visible]
    lengths = [np.linalg.norm(np.diff(s.points_m, axis=0), axis=1)[b].sum()
               for s, b in zip(scene.seams, seen)]
    assert max(lengths) >= 0.05


def test_the_hires_sensor_renders_its_own_frame():
    scene, scan = draw_case("square_butt", 1, sensor="hires")
    assert scan.depth.shape == (1200, 1944)
    assert scan.intrinsics.depth_scale == 10000.0
    assert len(scan.points_m) > 1_000_000


def test_groups_and_bad_names():
    assert set(GROUPS["all"]) == set(ALL_FAMILIES) == set(FAMILIES) | set(NEW_FAMILIES)
    assert not set(FAMILIES) & set(NEW_FAMILIES)
    with pytest.raises(ValueError, match="unknown family 'nope'"):
        draw_case("nope", 0)
    with pytest.raises(ValueError, match="unknown sensor 'kinect'"):
        draw_case("v_butt", 0, sensor="kinect")
