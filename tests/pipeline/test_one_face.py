import numpy as np
import pytest

from weldseam.config import JointsConfig
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.one_face import one_face_corner

PARAMS = JointsConfig()
UP = (0.0, 1.0)  # the camera straight above, in the section plane (u across, w up)


def flange(rng, end_u=0.004, start_u=-0.025, noise=0.0002, pitch=0.0006):
    """A flange (w = 0) seen from u = start_u up to its end at the web's foot, `end_u`."""
    u = np.arange(start_u, end_u + 1e-9, pitch)
    return u, rng.normal(0.0, noise, len(u))


def wall_top(height=0.05, lean_u=0.0, runs_along=True):
    """sight(): the line of sight past the flange's end meets the web's top, `height` above the
    foot (leaning `lean_u` across), for any point past the end; nothing before it. The top runs
    along the seam, or (runs_along False) it is one silhouette edge, met at the same place from
    every point along."""
    return lambda u, w, along=0.0: (0.004 + lean_u, height, along if runs_along else 0.0) if u > 0.004 else None


def test_a_flange_ending_under_a_wall_top_is_a_corner_with_the_bisector(rng):
    u, w = flange(rng)
    fit = one_face_corner(u, w, UP, wall_top(), PARAMS, 0.025)
    assert fit.kind == JointKind.FILLET and fit.geometry.faces_seen == 1
    assert abs(fit.u - 0.004) < 0.0004 and abs(fit.w) < 0.0004
    expected = -np.array([-1.0, 1.0]) / np.sqrt(2)  # into the corner: between -u (flange) and +w (wall)
    assert np.degrees(np.arccos(np.clip(np.array([fit.axis_u, fit.axis_w]) @ expected, -1, 1))) < 2.0
    assert abs(fit.geometry.included_deg - 90.0) < 2.0


def test_a_plate_edge_with_nothing_nearer_past_it_is_not_a_corner(rng):
    u, w = flange(rng)
    assert one_face_corner(u, w, UP, lambda u, w, along=0.0: None, PARAMS, 0.025) is None


def test_a_low_step_past_the_end_is_not_a_wall(rng):
    u, w = flange(rng)
    assert one_face_corner(u, w, UP, wall_top(height=0.006), PARAMS, 0.025) is None  # under a fillet leg


def test_the_far_side_of_a_wall_seen_from_behind_is_a_shadow_not_its_foot(rng):
    """The camera leans over the wall from its far side: the flange's end is the edge of the wall's
    shadow, and the line of sight past it meets the wall's top."""
    u, w = flange(rng)
    from_behind = (np.sin(np.radians(20)), np.cos(np.radians(20)))
    assert one_face_corner(u, w, from_behind, wall_top(), PARAMS, 0.025) is None
    from_the_flanges_side = (-np.sin(np.radians(10)), np.cos(np.radians(10)))  # the wall edge-on: seen
    assert one_face_corner(u, w, from_the_flanges_side, wall_top(), PARAMS, 0.025) is not None


@pytest.mark.parametrize("lean_deg", [15.0, -15.0])
def test_a_wall_far_from_square_is_not_taken_from_its_top_alone(rng, lean_deg):
    u, w = flange(rng)
    sight = wall_top(height=0.05, lean_u=0.05 * np.tan(np.radians(lean_deg)))
    assert one_face_corner(u, w, UP, sight, PARAMS, 0.025) is None


def test_mixed_pixels_past_the_end_and_a_hole_in_the_flange_do_not_move_the_corner(rng):
    u, w = flange(rng)
    hole = (u > -0.012) & (u < -0.008)  # a dropout in the flange: its edges are no ends
    u, w = u[~hole], w[~hole]
    mixed_u, mixed_w = np.array([0.0046, 0.0051]), np.array([0.004, 0.009])  # between the flange and the top
    fit = one_face_corner(np.r_[u, mixed_u], np.r_[w, mixed_w], UP, wall_top(), PARAMS, 0.025)
    assert abs(fit.u - 0.004) < 0.0004


def test_a_flange_ending_in_a_posts_shadow_is_marked_as_placed_from_an_outline(rng):
    """Past a standing pipe the flange ends where the pipe hides it: the shadow's edge runs along
    the line of sight, and every sight past it meets the pipe's one silhouette edge, which does not
    run along with the section as a wall's top does."""
    u, w = flange(rng)
    assert one_face_corner(u, w, UP, wall_top(runs_along=False), PARAMS, 0.025).geometry.outline_wall
    assert not one_face_corner(u, w, UP, wall_top(runs_along=True), PARAMS, 0.025).geometry.outline_wall


def test_a_wall_ending_beside_the_section_is_found_looking_back_along_it(rng):
    """At a web's end the sight further along meets nothing; looking back along the seam it meets
    the top as far back."""
    u, w = flange(rng)
    top = wall_top()
    ends_here = lambda u_, w_, along=0.0: top(u_, w_, along) if along <= 0 else None  # noqa: E731
    assert not one_face_corner(u, w, UP, ends_here, PARAMS, 0.025).geometry.outline_wall


def test_a_dropout_in_the_wall_top_beside_the_section_does_not_make_it_an_outline(rng):
    """The sights along the seam meet nothing (holes in the web's top): nothing says the top stays
    put, and the corner stands as a web's."""
    u, w = flange(rng)
    top = wall_top()
    only_here = lambda u_, w_, along=0.0: top(u_, w_, along) if along == 0 else None  # noqa: E731
    assert not one_face_corner(u, w, UP, only_here, PARAMS, 0.025).geometry.outline_wall


def flange_both_sides(rng, foot=(0.004, 0.016)):
    """A flange (w = 0) across the whole window but for the stretch `foot` (u from, to) a wall
    stands on and shadows: a T-joint's flange either side of its web, seen from above."""
    u, w = flange(rng, end_u=0.025)
    keep = (u <= foot[0]) | (u >= foot[1])
    return u[keep], w[keep]


def web_top(over=(0.004, 0.010), height=0.05, ends_here=False):
    """sight(): lines of sight from the flange's gap (u 0.004-0.016) meet the web's top, standing
    over `over` (u from, to) `height` up; the top runs along the seam, or (ends_here) the web ends
    at this section and only looking back along the seam meets it."""
    def sight(u, w, along=0.0):
        if not 0.004 < u < 0.016 or (ends_here and along > 0):
            return None
        return (min(max(u, over[0]), over[1]), height, along - (0.002 if ends_here else 0.0))
    return sight


def test_a_flange_going_on_beyond_the_web_ends_at_the_web_and_is_a_corner(rng):
    """The web's foot and shadow leave a gap in the flange, which goes on beyond it along the same
    line: with the web's top standing over the gap, the near flange's end is the corner."""
    u, w = flange_both_sides(rng)
    fit = one_face_corner(u, w, UP, web_top(), PARAMS, 0.025)
    assert fit is not None and fit.geometry.faces_seen == 1
    assert abs(fit.u - 0.004) < 0.0004 and abs(fit.w) < 0.0004


def test_a_gap_in_the_flange_past_a_webs_end_is_its_shadow_and_no_corner(rng):
    """Past the web's end the sights over the gap meet the web's end, behind: nothing stands over
    the gap along the seam, the flange goes on across it, and no face ends there."""
    u, w = flange_both_sides(rng)
    assert one_face_corner(u, w, UP, web_top(ends_here=True), PARAMS, 0.025) is None


def test_a_top_seen_beside_the_gap_is_no_wall_standing_in_it(rng):
    """A surface the lines of sight over the gap meet beyond its sides (another part, far off
    across the section) stands on no part of the flange's gap: the gap is a hole."""
    u, w = flange_both_sides(rng)
    assert one_face_corner(u, w, UP, web_top(over=(0.022, 0.024)), PARAMS, 0.025) is None
