"""A corner whose one face is unseen, that face carried on along its ruling from the full fits."""

import numpy as np
import pytest

from weldseam.config import JointsConfig
from weldseam.geometry import unit
from weldseam.pipeline.carried import carried_corner, corner_template
from weldseam.pipeline.joints import JointGeometry, JointKind
from weldseam.pipeline.section import SectionFit

HALF_WIDTH_M = 0.025
PIPE_RADIUS_M = 0.03


def ring_fillet_fits(count=8, arc_m=0.03):
    """Full fits along the foot of a pipe standing on a plate (z up, axis z, radius
    PIPE_RADIUS_M): the seam point, the torch axis (the bisector, into the corner) and 90
    degrees included; each with its travel (counter-clockwise seen from above)."""
    angles = np.linspace(0.0, arc_m / PIPE_RADIUS_M, count)
    out = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(count)])
    travel = np.column_stack([-np.sin(angles), np.cos(angles), np.zeros(count)])
    fits = [SectionFit(JointKind.FILLET, PIPE_RADIUS_M * o, -unit(o + np.array([0.0, 0.0, 1.0])),
                       JointGeometry(included_deg=90.0)) for o in out]  # fmt: skip
    return fits, travel, out


def test_a_pipes_wall_is_carried_along_its_axis_and_the_plate_in_its_plane():
    fits, travel, out = ring_fillet_fits()
    template = corner_template(fits, travel)
    # Travel counter-clockwise with the torch pointing in and down: the pipe is on the right.
    plate, pipe = template.left, template.right
    assert np.degrees(np.arccos(pipe @ [0.0, 0.0, 1.0])) < 1.0, "a pipe's ruling is its axis, pointing up"
    assert abs(plate[2]) < 1e-6 and plate @ out[-1] > 0.99, "the plate's: in the plate, away from the pipe"


def test_too_few_full_fits_give_no_template():
    fits, travel, _ = ring_fillet_fits()
    one_face = [SectionFit(f.kind, f.point_m, f.torch_axis, JointGeometry(included_deg=90.0, faces_seen=1), flags=1)
                for f in fits]  # fmt: skip
    assert corner_template(one_face[:5] + fits[5:], travel) is None


def seen_face(rng, slope=0.45, end_u=0.0, noise=0.0002, pitch=0.0005):
    """A face w = slope (u - end_u) for u from end_u to the window's edge (the right side)."""
    u = np.arange(end_u, HALF_WIDTH_M, pitch)
    return u, slope * (u - end_u) + rng.normal(0, noise, len(u))


def corner_of(u, w, unseen, toward):
    order = np.argsort(u)
    return carried_corner(u[order], w[order], {-1: unit(np.asarray(unseen))}, unit(np.asarray(toward)), JointsConfig(),
                          HALF_WIDTH_M)  # fmt: skip


UNSEEN_WALL = (-0.82, 0.57)  # up and to the left: 125 degrees from a face of slope 0.45
GRAZING = (-0.678, 0.735)  # the wall seen at 77 degrees of incidence, the face at 19


def test_a_face_ending_where_the_carried_face_turns_away_from_the_camera_is_a_corner_with_the_bisector(rng):
    u, w = seen_face(rng)
    fit = corner_of(u, w, UNSEEN_WALL, GRAZING)
    assert fit is not None and fit.kind == JointKind.FILLET and fit.geometry.faces_seen == 1
    assert np.hypot(fit.u, fit.w) < 0.0004
    bisector = -unit(unit(np.array([1.0, 0.45])) + unit(np.array(UNSEEN_WALL)))
    assert np.degrees(np.arccos(np.clip(bisector @ [fit.axis_u, fit.axis_w], -1, 1))) < 2.0
    assert fit.geometry.included_deg == pytest.approx(np.degrees(np.arccos(unit(np.array([1.0, 0.45])) @ unit(
        np.array(UNSEEN_WALL)))), abs=1.5)  # fmt: skip


def test_the_grazing_foot_of_the_unseen_face_does_not_move_the_corner(rng):
    """A few points of the unseen face's foot, measured at grazing incidence, lie past the seen
    face's end: the corner is where the face turns into the carried direction, not the last point."""
    u, w = seen_face(rng)
    foot = np.linspace(0.0005, 0.003, 6)
    wall = unit(np.array(UNSEEN_WALL))
    u = np.concatenate([u, foot * wall[0]])
    w = np.concatenate([w, foot * wall[1] + rng.normal(0, 0.0002, len(foot))])
    fit = corner_of(u, w, UNSEEN_WALL, GRAZING)
    assert fit is not None and np.hypot(fit.u, fit.w) < 0.0005


def test_a_wall_facing_the_camera_but_lost_in_a_dropout_or_a_stereo_shadow_is_carried(rng):
    """Seen squarely (18 degrees from the wall's normal) the wall should have been measured; a
    dropout or the sensor's stereo shadow lost it, and the face seen still runs up to the corner:
    the same corner as at grazing incidence."""
    u, w = seen_face(rng)
    fit = corner_of(u, w, UNSEEN_WALL, (0.3, 0.95))
    assert fit is not None and fit.geometry.faces_seen == 1 and np.hypot(fit.u, fit.w) < 0.0004


def test_no_corner_where_the_unseen_face_hides_the_face_end(rng):
    """Seen from behind (107 degrees), the wall hides the face's end: that is a shadow's edge."""
    u, w = seen_face(rng)
    assert corner_of(u, w, UNSEEN_WALL, (-0.95, 0.3)) is None


def test_a_face_running_out_of_the_window_or_on_past_the_corner_is_no_corner(rng):
    u, w = seen_face(rng, end_u=-HALF_WIDTH_M + 0.001)
    assert corner_of(u, w, UNSEEN_WALL, GRAZING) is None, "the face runs out of the window"
    u, w = seen_face(rng, end_u=-HALF_WIDTH_M + 0.001, slope=0.0)
    assert corner_of(u, w, UNSEEN_WALL, GRAZING) is None, "a flat plate across the window has no end"
