"""Supports, clamps and loose bars: they stand on the table or lie on the part, never inside
it, never on a seam."""

import numpy as np
import pytest
import trimesh

from tests.synthetic.checks import distance_to_mesh, signed_distance
from weldseam.synthetic.catalog import ALL_FAMILIES
from weldseam.synthetic.fixtures import SEAM_CLEARANCE_M, add_clutter, rest_on_support
from weldseam.synthetic.joints import bevel, lap, square_butt

TOUCH_M = 2e-6  # Open3D's float32 distances; solids that touch come out within this


def _samples(mesh, count=4000):
    """Vertices and `count` evenly spread surface points of a mesh (fixed seed)."""
    return np.vstack([mesh.vertices, trimesh.sample.sample_surface_even(mesh, count, seed=0)[0]])


def _assert_apart(first, second):
    """Two closed meshes share no volume: no surface point of one lies inside the other."""
    assert signed_distance(second, _samples(first)).min() > -TOUCH_M
    assert signed_distance(first, _samples(second)).min() > -TOUCH_M


@pytest.mark.parametrize("family", ["v_butt", "fillet_t", "ring_groove", "two_grooves",
                                    "block_groove", "plain_plate", "lap", "tacked", "bevel"])
@pytest.mark.parametrize("seed", [0, 1])
def test_clamps_and_bars_never_intersect_the_part_or_each_other(family, seed):
    rng = np.random.default_rng(seed)
    flat = {"mount": "table"} if family in ("lap", "bevel") else {}  # clamps need a level top
    plain = ALL_FAMILIES[family](rng, **flat)
    scene = add_clutter(plain, rng, clamps=2, bars=2)
    added = scene.fixtures[len(plain.fixtures):]
    assert len(added) >= 3  # pieces of at least one clamp and one bar
    assert scene.seams is plain.seams
    for k, fixture in enumerate(added):
        assert fixture.is_volume
        for part in (*scene.parts, *plain.fixtures, *added[k + 1:]):
            _assert_apart(fixture, part)
        below = fixture.vertices[:, 2].min()
        resting = below == pytest.approx(0.0, abs=1e-9) or min(
            distance_to_mesh(part, fixture.vertices).min() for part in scene.parts
        ) < TOUCH_M or any(distance_to_mesh(other, fixture.vertices).min() < TOUCH_M
                           for other in added if other is not fixture)
        assert resting  # on the table, on the part, or on its own post
        for seam in scene.seams:
            assert distance_to_mesh(fixture, seam.points_m).min() >= SEAM_CLEARANCE_M - 1e-4


def test_no_clamp_where_no_flat_top_meets_an_edge():
    rng = np.random.default_rng(3)
    scene = ALL_FAMILIES["pipe_groove"](rng)
    assert add_clutter(scene, rng, clamps=2, bars=0) is scene


@pytest.mark.parametrize("kind", ["wedge", "blocks"])
@pytest.mark.parametrize("family", [lap, bevel, square_butt])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_part_on_a_support_is_tilted_15_to_35_deg_and_rests_on_it(kind, family, seed):
    scene = family(np.random.default_rng(seed), mount=kind)
    plate = scene.parts[0]
    normal = plate.face_normals[np.argmax(plate.area_faces)]  # a plate's largest face
    tilt = np.degrees(np.arccos(abs(normal[2])))
    lowest = min(part.vertices[:, 2].min() for part in scene.parts)
    assert 0.01 - 1e-9 <= lowest <= 0.03 + 1e-9
    supports = scene.fixtures[-2:] if kind == "blocks" else scene.fixtures[-1:]
    for support in supports:
        assert support.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-12)
        touching = [p for p in scene.parts if distance_to_mesh(p, support.vertices).min() < TOUCH_M]
        assert touching
        for part in scene.parts:
            _assert_apart(support, part)
    assert 15.0 - 1e-6 <= tilt <= 35.0 + 1e-6


def test_rest_on_support_rejects_an_unknown_kind():
    with pytest.raises(ValueError, match="wedge"):
        rest_on_support([], [], np.random.default_rng(0), "crate")
