import numpy as np
import pytest

from weldseam.config import JointsConfig
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.one_face_ridge import one_face_ridge

PARAMS = JointsConfig()
HALF_WIDTH_M = 0.025
ROOT = np.sqrt(0.5)
# A square roof in the section plane (u across, w up along the corner's outward bisector), the
# seam (the V's opening middle) at the origin: face A runs down-left from the apex, face B
# down-right, and the V's top edges lie HALF_OPENING_M either side of the seam.
HALF_OPENING_M = 0.0025
DEPTH_M = 0.004
EDGE_A, EDGE_B = np.array([-HALF_OPENING_M, 0.0]), np.array([HALF_OPENING_M, 0.0])
BOTTOM = np.array([0.0, -DEPTH_M])
# The camera 30 degrees off the bisector on face A's side: A seen at 15 degrees of incidence, B at 75.
FROM_A_SIDE = (-np.sin(np.radians(30)), np.cos(np.radians(30)))


def segment(start, end, pitch, rng, noise=0.0002):
    """Points every `pitch` (m) from `start` to `end` (u, w), noisy in w."""
    count = max(int(np.linalg.norm(np.subtract(end, start)) / pitch), 2)
    t = np.linspace(0.0, 1.0, count)[:, None]
    points = np.asarray(start) + t * (np.asarray(end) - np.asarray(start))
    points[:, 1] += rng.normal(0.0, noise, count)
    return points


def profile(*parts):
    """(u, w) ascending of the points of `parts`."""
    points = np.vstack(parts)
    order = np.argsort(points[:, 0], kind="stable")
    return points[order, 0], points[order, 1]


def face_a(rng, length=0.02):
    return segment(EDGE_A + length * np.array([-ROOT, -ROOT]), EDGE_A, 0.0006, rng)


def assert_on_the_seam(fit):
    assert fit.kind == JointKind.OUTSIDE_CORNER and fit.geometry.faces_seen == 1
    assert np.hypot(fit.u, fit.w) < 0.0004
    assert np.degrees(np.arccos(np.clip(np.array([fit.axis_u, fit.axis_w]) @ [0.0, -1.0], -1, 1))) < 2.0
    assert abs(fit.geometry.opening_m - 2 * HALF_OPENING_M) < 0.0008


def test_the_far_wall_of_the_v_gives_its_far_edge(rng):
    u, w = profile(face_a(rng), segment(BOTTOM, EDGE_B, 0.0004, rng))
    assert_on_the_seam(one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M))


def test_a_rounded_square_edge_is_not_a_v_with_its_far_face_seen(rng):
    """A plate's square edge whose rounding ends the top face 2 mm short of the corner, its end face
    going down square: the same points as a hidden V with a little of face B seen. Only the V's far
    wall places the far edge."""
    corner = EDGE_A + 0.002 * np.array([ROOT, ROOT])
    end_face = segment(corner + 0.0015 * np.array([ROOT, -ROOT]), corner + 0.006 * np.array([ROOT, -ROOT]),
                       0.0005, rng)
    u, w = profile(face_a(rng), end_face)
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


def test_the_seen_face_on_the_right_is_the_mirror_image(rng):
    u, w = profile(face_a(rng), segment(BOTTOM, EDGE_B, 0.0004, rng))
    fit = one_face_ridge(-u[::-1], w[::-1], (-FROM_A_SIDE[0], FROM_A_SIDE[1]), PARAMS, HALF_WIDTH_M)
    assert_on_the_seam(fit)


def test_a_face_the_camera_would_see_squarely_is_not_unseen(rng):
    """From face B's side, a square face B would have been measured: its absence says no such face."""
    u, w = profile(face_a(rng), segment(BOTTOM, EDGE_B, 0.0004, rng))
    assert one_face_ridge(u, w, (np.sin(np.radians(30)), np.cos(np.radians(30))), PARAMS, HALF_WIDTH_M) is None


def test_a_groove_between_level_plates_is_no_outside_corner(rng):
    """A plate going on level beyond a V (a V-groove with its near wall hidden) stands above the
    opening line of a square corner."""
    tilt = np.array([ROOT, ROOT])  # face A's direction: the plates level along it
    far_plate = segment(EDGE_B, EDGE_B + 0.015 * tilt, 0.0006, rng)
    u, w = profile(face_a(rng), segment(BOTTOM, EDGE_B, 0.0004, rng), far_plate)
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


def test_a_square_edge_without_a_v_is_no_outside_corner(rng):
    """A plate's square edge: face B starts where face A ends, with no opening between them."""
    apex = np.array([0.0, HALF_OPENING_M])
    top = segment(apex + 0.02 * np.array([-ROOT, -ROOT]), apex, 0.0006, rng)
    end_face = segment(apex, apex + 0.004 * np.array([ROOT, -ROOT]), 0.0005, rng)
    u, w = profile(top, end_face)
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


@pytest.mark.parametrize("length", [0.006, 0.009])
def test_a_short_face_is_not_enough_to_place_the_corner(rng, length):
    u, w = profile(face_a(rng, length), segment(BOTTOM, EDGE_B, 0.0004, rng))
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


def test_the_near_wall_alone_does_not_place_the_far_edge(rng):
    """The V's near wall leans like face B would, but runs from face A's own edge."""
    u, w = profile(face_a(rng), segment(EDGE_A + [0.0003, -0.0004], BOTTOM, 0.0004, rng))
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


def test_a_lower_surface_going_on_past_a_thick_plates_edge_is_no_far_wall(rng):
    """The table beyond a 13 mm plate's edge runs parallel to the plate's top: a wall leaning 45
    degrees off the bisector, as an open corner's would."""
    along, normal = np.array([ROOT, ROOT]), np.array([-ROOT, ROOT])
    table = segment(EDGE_A - 0.013 * normal + 0.002 * along, EDGE_A - 0.013 * normal + 0.014 * along, 0.0005, rng)
    u, w = profile(face_a(rng), table)
    # The section centred between the plate's edge and the table's points (as a chain along the
    # edge places it): the far "edge", 18 mm from the plate's, lies inside the window.
    assert one_face_ridge(u - 0.009, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


def test_a_surface_standing_above_the_opening_line_farther_on_is_no_face_b(rng):
    """Past a square corner's far edge face B falls away: a plate going on level beyond the V, seen
    again past a dropout, stands above the opening line there."""
    along = np.array([ROOT, ROOT])
    far_plate = segment(EDGE_B + 0.022 * along, EDGE_B + 0.028 * along, 0.0006, rng)
    u, w = profile(face_a(rng), segment(BOTTOM, EDGE_B, 0.0004, rng), far_plate)
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


def test_a_surface_reaching_back_under_the_seen_faces_end_is_no_far_wall(rng):
    """A V's far wall rises from the root, under the opening's middle; a lower surface leaning like
    one but running back under E_A is something going on beyond the face's end."""
    lower = segment(EDGE_A + [0.001, -0.009], EDGE_A + [0.008, 0.0], 0.0004, rng)
    u, w = profile(face_a(rng), lower)
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None


def test_a_notch_narrower_than_an_opening_is_no_v(rng):
    notch_wall = segment(EDGE_A + [0.0005, -0.002], EDGE_A + [0.001, 0.0], 0.0002, rng)
    u, w = profile(face_a(rng), notch_wall)
    assert one_face_ridge(u, w, FROM_A_SIDE, PARAMS, HALF_WIDTH_M) is None
