"""The fillet model (weldseam/pipeline/joints/fillet.py) on corners whose faces are curved, and on
shallow valleys, against profiles whose corner and bisector are known analytically."""

import numpy as np
import pytest

from weldseam.config import JointsConfig
from weldseam.geometry import unit
from weldseam.pipeline.joints import JointKind, NoFit, fit_profile
from weldseam.pipeline.joints.faces import best_break, fit_face, meeting_point
from weldseam.synthetic.valley import valley_profile

PARAMS = JointsConfig()


def framed(offsets, heights, normals, rng, noise_m, pitch_m=0.0004, half_width_m=0.025):
    """A profile (u, w) sampled every pitch_m across a (offset, height) outline, in the frame whose
    w is the bisector of the two outward face normals at the corner (offset 0, height 0), with
    Gaussian noise along w; and the bisector's tilt (radians) from the outline's vertical."""
    bisector = unit(normals[0] + normals[1])
    lateral = np.array([bisector[1], -bisector[0]])
    points = np.column_stack([offsets, heights])
    u_outline, w_outline = points @ lateral, points @ bisector
    order = np.argsort(u_outline)
    u = np.arange(-half_width_m, half_width_m, pitch_m) + rng.uniform(-pitch_m / 4, pitch_m / 4)
    inside = (u > u_outline.min()) & (u < u_outline.max())
    u = u[inside]
    w = np.interp(u, u_outline[order], w_outline[order]) + rng.normal(0, noise_m, len(u))
    return u, w


def tube_valley(radii_m, slopes_deg, rng, noise_m=0.0001):
    """Two circular arcs (tube flanks) meeting in a valley at the origin: profile and normals."""
    offsets, heights, normals = valley_profile(radii_m, slopes_deg, 0.03)
    return framed(offsets, heights - 0.03, normals, rng, noise_m)


@pytest.mark.parametrize(("radii_m", "slopes_deg"), [((0.047, 0.034), (15.6, 15.2)), ((0.03, 0.055), (25.0, 20.0))])
def test_a_shallow_valley_between_two_tubes_is_a_fillet_at_its_crease(rng, radii_m, slopes_deg):
    """Included 135-150 degrees, faces arcs of 30-55 mm radius: the corner is the crease and the
    torch axis the bisector of the faces there (the frame's w)."""
    u, w = tube_valley(radii_m, slopes_deg, rng)
    fit = fit_profile(u, w, PARAMS)
    assert fit.kind == JointKind.FILLET
    assert np.hypot(fit.u, fit.w) < 0.0002
    assert np.degrees(np.arctan2(abs(fit.axis_u), -fit.axis_w)) < 1.0
    # A parabola follows a tube's arc over a face's reach to a degree or two of the tangent.
    assert abs(fit.geometry.included_deg - (180.0 - sum(slopes_deg))) < 3.0


def test_a_corner_against_a_pipe_wall_is_found_where_the_arc_meets_the_wall(rng):
    """A saddle's section: a straight wall rising 70 degrees to the left of the corner, and a main
    pipe's surface descending 20 degrees to the right of it, curving away over a 45 mm radius
    (included 130 degrees). Two straight lines through the arc miss the corner by ~1 mm; the
    arc's own tangent at the corner sets the bisector."""
    wall, slope, radius = np.radians(70.0), np.radians(20.0), 0.045
    t = np.linspace(0.03, 0.0, 300, endpoint=False)
    phi = np.linspace(0.0, 0.03 / radius, 300)
    pipe_normal = np.array([np.sin(slope), np.cos(slope)])  # outward, at the corner
    centre = -radius * pipe_normal
    offsets = np.concatenate([-t * np.cos(wall), centre[0] + radius * np.sin(slope + phi)])
    heights = np.concatenate([t * np.sin(wall), centre[1] + radius * np.cos(slope + phi)])
    normals = (np.array([np.sin(wall), np.cos(wall)]), pipe_normal)
    u, w = framed(offsets, heights, normals, rng, 0.0001)
    fit = fit_profile(u, w, PARAMS)
    assert fit.kind == JointKind.FILLET
    assert np.hypot(fit.u, fit.w) < 0.00015
    assert np.degrees(np.arctan2(abs(fit.axis_u), -fit.axis_w)) < 1.0
    assert abs(fit.geometry.included_deg - 130.0) < 1.5


def test_a_gently_bent_plate_has_no_crease(rng):
    """A plate bent by 15 degrees over a 40 mm radius, and a plate with a D415-like ripple (0.25 mm
    over 40 mm), are no joints, where a 150-degree crease between tubes is. (Bent by 30 degrees or
    more over a few cm, a plate is a valley rounded at its bottom, taken as a fillet.)"""
    bend, radius = np.radians(7.5), 0.040
    s = np.linspace(-0.04, 0.04, 801)
    # A symmetric bend: straight, an arc turning 2 x 15 degrees over radius x 30 degrees, straight.
    angle = np.clip(s / radius, -bend, bend)
    offsets = np.concatenate([[0.0], np.cumsum(np.cos(angle[:-1]) * np.diff(s))])
    heights = np.concatenate([[0.0], np.cumsum(np.sin(angle[:-1]) * np.diff(s))])
    offsets, heights = offsets - np.interp(0.0, s, offsets), heights - np.interp(0.0, s, heights)
    normals = (np.array([np.sin(bend), np.cos(bend)]), np.array([-np.sin(bend), np.cos(bend)]))
    assert isinstance(fit_profile(*framed(offsets, heights, normals, rng, 0.0001), PARAMS), NoFit)
    u = np.arange(-0.025, 0.025, 0.0004)
    rippled = 0.00025 * np.cos(2 * np.pi * u / 0.04) + rng.normal(0, 0.0002, len(u))
    assert isinstance(fit_profile(u, rippled, PARAMS), NoFit)
    assert fit_profile(*tube_valley((0.04, 0.04), (15.0, 15.0), rng), PARAMS).kind == JointKind.FILLET


def test_a_face_curving_tighter_than_20_mm_is_an_edge_not_a_face(rng):
    """Arcs of 40 mm radius meeting at 150 degrees are two faces; of 8 mm radius, each "face" turns
    over its crest within a few mm, as much as the crease does: the corner is a wave of the
    surface, not a joint. Across a V-groove a circle or parabola follows each wall up over its
    edge onto the plate: an edge, not a face, and the groove's root is no fillet."""
    for radius, is_fillet in ((0.04, True), (0.008, False)):
        offsets, heights, normals = valley_profile((radius, radius), (15.0, 15.0), 0.03, max_far_deg=89.0)
        u, w = framed(offsets, heights - 0.03, normals, rng, 0.00005)
        assert isinstance(fit_profile(u, w, PARAMS, {JointKind.FILLET}), NoFit) != is_fillet, radius
    for half_open, depth in ((0.008, 0.010), (0.012, 0.012)):  # walls 13 and 17 mm long
        u = np.arange(-0.025, 0.025, 0.0004)
        w = -np.clip((half_open - np.abs(u)) * depth / half_open, 0, None) + rng.normal(0, 0.0003, len(u))
        assert isinstance(fit_profile(u, w, PARAMS, {JointKind.FILLET}), NoFit)


def test_the_break_of_two_parabolas_is_where_they_meet():
    u = np.linspace(-0.02, 0.02, 201)
    t = u - 0.003
    w = np.where(t < 0, -0.5 * t + 8.0 * t**2, 0.7 * t - 5.0 * t**2)
    split = best_break(u, w)
    assert abs(split.u - 0.003) < 0.00025 and split.error < 1e-12
    left = fit_face(u[: split.index], w[: split.index], (split.u, split.w), -1.0)
    right = fit_face(u[split.index :], w[split.index :], (split.u, split.w), 1.0)
    assert left.curved and right.curved
    corner_u = meeting_point(left, right, split.u)
    assert abs(corner_u - 0.003) < 1e-6 and abs(left.at(corner_u)) < 1e-8


def test_a_straight_face_stays_a_line(rng):
    u = np.linspace(0.0, 0.02, 60)
    w = 0.4 * u + rng.normal(0, 0.0003, len(u))
    face = fit_face(u, w, (0.0, 0.0), 1.0)
    assert not face.curved and abs(face.slope(0.0) - 0.4) < 0.05
