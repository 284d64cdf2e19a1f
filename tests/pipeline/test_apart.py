"""Apart against analytic clouds: an inside corner along y at the origin between a floor (z = 0,
x > 0) and a wall (x = 0, z > 0), torch axis into the corner; in the "apart" cloud the wall is a
post's side ending 5 mm above the floor, and the floor runs on 6 mm under it (x < 0), seen through
the gap. And the project's own broad block scene whose clamp post was traced as a fillet."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from tests.conftest import planned_broad_case, rejected_gaps_to_fixtures_m
from weldseam.config import PlanConfig
from weldseam.pipeline.apart import joined_seams, standing_apart
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import FineSurface, section_params
from weldseam.pipeline.trace import TracedSeam

AXIS = np.array([-1.0, 0.0, -1.0]) / np.sqrt(2.0)


def corner_surface(rng, wall_from_m: float, floor_from_m: float) -> FineSurface:
    """Floor points x in [floor_from_m, 25 mm] at z = 0 and wall points z in [wall_from_m, 25 mm]
    at x = 0, every 0.5 mm, extruded 60 mm along y every mm, 0.2 mm noise."""
    floor_x = np.arange(floor_from_m, 0.025, 0.0005)
    floor = np.column_stack([floor_x, np.zeros(len(floor_x))])
    wall_z = np.arange(wall_from_m, 0.025, 0.0005)
    profile = np.vstack([floor, np.column_stack([np.zeros(len(wall_z)), wall_z])])
    y = np.arange(0.0, 0.06, 0.001)
    points = np.column_stack([np.tile(profile[:, 0], len(y)), np.repeat(y, len(profile)),
                              np.tile(profile[:, 1], len(y))])  # fmt: skip
    points += rng.normal(0.0, 0.0002, points.shape)
    return FineSurface(points, cKDTree(points), section_params(PlanConfig()))


def corner_seam(joint=JointKind.FILLET) -> TracedSeam:
    line = np.column_stack([np.zeros(25), np.linspace(0.005, 0.055, 25), np.zeros(25)])
    return TracedSeam(line, np.tile(AXIS, (25, 1)), False, joint, 1.0)


def test_a_corner_whose_faces_meet_is_kept(rng):
    seam = corner_seam()
    surface = corner_surface(rng, wall_from_m=0.0, floor_from_m=0.0)
    assert not standing_apart(seam, surface)
    assert joined_seams([seam], surface) == [seam]


def test_a_corner_whose_floor_runs_on_under_a_post_standing_apart_is_dropped(rng):
    seam = corner_seam()
    surface = corner_surface(rng, wall_from_m=0.005, floor_from_m=-0.006)
    assert standing_apart(seam, surface)
    assert joined_seams([seam], surface) == []


def test_a_groove_is_not_read_as_a_corner(rng):
    seam = corner_seam(JointKind.V_GROOVE)
    assert not standing_apart(seam, corner_surface(rng, wall_from_m=0.005, floor_from_m=-0.006))


@pytest.mark.parametrize("wall_from_m", [0.0, 0.003])
def test_a_face_seen_only_up_to_the_corner_is_no_run_behind(rng, wall_from_m):
    """A wall whose foot is not seen (a shadow) leaves no point behind the floor's line."""
    assert not standing_apart(corner_seam(), corner_surface(rng, wall_from_m=wall_from_m, floor_from_m=0.0))


def test_a_clamp_post_standing_beside_a_block_gives_no_fillet():
    """The project's own broad-world block with a V-groove (block_groove, seed 9): a clamp's post
    stands a few mm beside the block, its side turned to the block's side; the corner their faces
    made was a 97 mm vertical fillet up the post. Now the one seam is the groove, and the candidates
    rejected as standing apart lie at the post."""
    from weldseam.pipeline.candidates import Rejection

    scene, state = planned_broad_case("block_groove", 9, "split")
    truth = cKDTree(np.vstack([seam.points_m for seam in scene.seams]))
    assert len(state.seams) == 1 and np.median(truth.query(state.seams[0].positions_m)[0]) < 0.001
    gaps_m = rejected_gaps_to_fixtures_m(scene, state, Rejection.APART)
    assert gaps_m
    assert all(gap < 0.01 for gap in gaps_m)  # beside a fixture (the clamp's post)
