"""The lap model against analytic profiles: a top plate of thickness h lying on a bottom plate, its
edge at u = edge; the seam is the inside corner (edge, 0), the torch axis the bisector of the
bottom plate's normal and the edge face's, into the corner."""

from dataclasses import replace

import numpy as np
import pytest

from weldseam.config import JointsConfig
from weldseam.pipeline.joints import JointKind, NoFit, SortedProfile, fit_profile
from weldseam.pipeline.joints import lap

LAP = JointKind.LAP
PARAMS = JointsConfig()
PITCH_M = 0.0005


def lap_profile(rng, *, height=0.004, edge=0.002, top_side=1, noise=0.0003, face_seen=True, shadow_m=0.0,
                tilt_deg=0.0):
    """(u, w, corner (u, w), unit torch axis (u, w)) of a lap seen across its edge: the bottom plate
    at w = 0, the top plate at w = height on `top_side` (+1: u > edge), its edge face (seen or
    not), the bottom plate hidden `shadow_m` before the corner; the whole turned by `tilt_deg`
    (the section frame off the plates' normal)."""
    u = np.arange(-0.025, 0.025, PITCH_M)
    on_top = top_side * (u - edge) > 0
    w = np.where(on_top, height, 0.0)
    keep = on_top | (top_side * (edge - u) >= shadow_m)
    u, w = u[keep], w[keep]
    if face_seen:
        face_w = np.arange(PITCH_M, height, PITCH_M)
        u, w = np.append(u, np.full(len(face_w), edge)), np.append(w, face_w)
    w = w + rng.normal(0.0, noise, len(w))
    axis = np.array([top_side, -1.0]) / np.sqrt(2.0)  # toward the top plate's edge, down into the corner
    turn = np.radians(tilt_deg)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    points = np.column_stack([u, w]) @ rotation.T
    order = np.argsort(points[:, 0])
    return points[order, 0], points[order, 1], rotation @ [edge, 0.0], rotation @ axis


def assert_corner(fit, corner, axis, tolerance_m=0.0003, tolerance_deg=2.0):
    assert fit.kind == LAP
    assert np.hypot(fit.u - corner[0], fit.w - corner[1]) < tolerance_m
    assert np.degrees(np.arccos(np.clip(fit.axis_u * axis[0] + fit.axis_w * axis[1], -1, 1))) < tolerance_deg


@pytest.mark.parametrize("top_side", [1, -1])
@pytest.mark.parametrize("height", [0.002, 0.004, 0.006])
def test_the_seam_is_the_inside_corner_at_the_top_plates_edge_and_the_torch_bisects_it(rng, top_side, height):
    u, w, corner, axis = lap_profile(rng, height=height, edge=0.002 * top_side, top_side=top_side)
    assert_corner(fit_profile(u, w, PARAMS), corner, axis)


def test_a_grazing_edge_face_unseen_still_gives_the_corner(rng):
    u, w, corner, axis = lap_profile(rng, face_seen=False)
    assert_corner(fit_profile(u, w, PARAMS), corner, axis)


def test_a_corner_shadowed_by_the_top_plate_is_placed_at_the_top_plates_edge(rng):
    """Seen from the top plate's side, the bottom plate is hidden for a few mm before the corner:
    the corner is where the top plate ends, not the middle of the gap."""
    u, w, corner, axis = lap_profile(rng, face_seen=False, shadow_m=0.004)
    assert_corner(fit_profile(u, w, PARAMS), corner, axis, tolerance_m=0.0005)


@pytest.mark.parametrize("tilt_deg", [-25.0, 15.0, 30.0])
def test_the_corner_is_found_in_a_frame_turned_off_the_plates(rng, tilt_deg):
    u, w, corner, axis = lap_profile(rng, tilt_deg=tilt_deg)
    assert_corner(fit_profile(u, w, PARAMS), corner, axis)


def test_depth_quantised_in_1_mm_steps_places_the_corner_on_average(rng):
    errors = []
    for _ in range(20):
        u, w, corner, axis = lap_profile(rng, height=0.003, tilt_deg=8.0, noise=0.0002)
        fit = fit_profile(u, np.round((w - 0.0001) / 0.001) * 0.001 + 0.0001, PARAMS)
        assert fit.kind == LAP
        errors.append(np.hypot(fit.u - corner[0], fit.w - corner[1]))
    assert np.mean(errors) < 0.0006


def test_noisy_profiles_place_the_corner_without_bias():
    rng = np.random.default_rng(0)
    offsets = []
    for _ in range(100):
        u, w, corner, axis = lap_profile(rng, height=0.003, noise=0.0006)
        fit = fit_profile(u, w, PARAMS)
        assert fit.kind == LAP
        offsets.append(fit.u - corner[0])
    assert abs(np.mean(offsets)) < 0.00015


def test_the_torch_split_aims_the_torch_toward_the_bottom_plate(rng):
    """joints.lap_torch_split_deg: the torch's angle from the bottom plate's surface."""
    u, w, corner, _ = lap_profile(rng)
    fit = fit_profile(u, w, replace(PARAMS, lap_torch_split_deg=60.0))
    assert fit.kind == LAP
    assert abs(np.degrees(np.arctan2(-fit.axis_w, fit.axis_u)) - 60.0) < 2.0


@pytest.mark.parametrize("shape", [
    lambda u: np.where(u > 0, 0.012, 0.0),  # a wall: taller than a lap's top plate
    lambda u: np.where(u > 0, 0.001, 0.0),  # a 1 mm depth step
    lambda u: 0.0 * u,  # a plane
    lambda u: np.abs(u) * 0.6,  # a concave crease
    lambda u: np.where(np.abs(u) < 0.003, -0.004, 0.0),  # a slot in a plate
])
def test_what_is_not_a_lap_gives_no_lap(rng, shape):
    u = np.arange(-0.025, 0.025, PITCH_M)
    w = shape(u) + rng.normal(0.0, 0.0003, len(u))
    assert isinstance(lap.fit(SortedProfile.of(u, w, PARAMS)), NoFit)


@pytest.mark.parametrize("radius_m", [0.04, 0.08, 0.12])
@pytest.mark.parametrize("tilt_deg", [0.0, 30.0])
def test_the_crown_of_a_curved_part_is_no_lap(radius_m, tilt_deg):
    """A tube's crown across 50 mm (40-120 mm radius, seen square or 30 degrees off), in 0.4 mm of
    noise and depth quantised in 1 mm steps: two parallel lines split anywhere on it leave a
    2-2.5 mm 'step', and the code before the bow test took it for a lap in 5-18 of 20 such
    sections. A plate's surface is flat; the crown's bows, so none is a lap."""
    u0 = np.arange(-0.025, 0.025, PITCH_M)
    w0 = np.sqrt(radius_m**2 - u0**2) - radius_m
    turn = np.radians(tilt_deg)
    u, w = np.cos(turn) * u0 - np.sin(turn) * w0, np.sin(turn) * u0 + np.cos(turn) * w0
    order = np.argsort(u)
    for seed in range(20):
        noisy = np.round((w[order] + np.random.default_rng(seed).normal(0.0, 0.0004, len(u))) / 0.001) * 0.001
        assert isinstance(lap.fit(SortedProfile.of(u[order], noisy, PARAMS)), NoFit)


def test_the_bow_of_a_plate_is_measured_beyond_its_noise(rng):
    """A flat plate's 10-40 mm in 0.5 mm of noise bows by no more than noise allows; a 40 mm
    radius crown over 25 mm does."""
    for length in (0.010, 0.040):
        x = np.arange(0.0, length, PITCH_M)
        assert not lap._bowed(x, 0.3 * x + rng.normal(0.0, 0.0005, len(x)))
    x = np.arange(-0.0125, 0.0125, PITCH_M)
    assert lap._bowed(x, np.sqrt(0.04**2 - x**2) + rng.normal(0.0, 0.0005, len(x)))


def test_a_step_with_too_little_of_either_plate_beside_it_is_no_lap(rng):
    u, w, _, _ = lap_profile(rng)
    near = np.abs(u - 0.002) < 0.004  # 4 mm of each plate
    assert isinstance(lap.fit(SortedProfile.of(u[near], w[near], PARAMS)), NoFit)


@pytest.mark.parametrize("top_side", [1, -1])
def test_a_dropout_hiding_either_plate_past_a_few_mm_leaves_the_lap(rng, top_side):
    """Sensor dropouts hide the bottom plate beyond the corner as often as the top plate beyond its
    edge: with 6 mm of either one seen (the lines are fitted parallel, the other plate gives the
    slope), the corner is still found."""
    u, w, corner, axis = lap_profile(rng, top_side=top_side, face_seen=False)
    for hidden in (top_side * (0.002 - u) > 0.006, top_side * (u - 0.002) > 0.006):
        assert_corner(lap.fit(SortedProfile.of(u[~hidden], w[~hidden], PARAMS)), corner, axis)


def test_a_groove_beside_a_step_is_no_lap(rng):
    """A plate's end seen with what lies below it, a V-groove in the plate 6-12 mm from the end:
    the plate does not run flat to its edge as a lap's top plate does."""
    u, w, _, _ = lap_profile(rng, height=0.004, edge=0.0, face_seen=False)
    groove = (u > 0.006) & (u < 0.012)
    w[groove] -= 0.003 * (1.0 - np.abs(u[groove] - 0.009) / 0.003)
    assert isinstance(lap.fit(SortedProfile.of(u, w, PARAMS)), NoFit)


@pytest.mark.parametrize("top_side", [1, -1])
def test_a_lower_surface_seen_empty_short_of_the_step_is_two_parts_apart(rng, top_side):
    # The bottom plate ends 8 mm short of a 3 mm step, the edge face unseen: a fixture's face
    # standing proud beside a block's. Seen from over the bottom plate (the camera would see the
    # edge face and the plate up to it) no lap; seen from over the top plate at 65 degrees, the
    # edge hides 6.4 mm of the bottom plate and the lap stands; so it does without a single camera.
    u, w, corner, axis = lap_profile(rng, height=0.003, edge=0.002 * top_side, top_side=top_side, face_seen=False,
                                     shadow_m=0.008)  # fmt: skip
    over_bottom = (-top_side * np.sin(np.radians(30)), np.cos(np.radians(30)))
    over_top = (top_side * np.sin(np.radians(65)), np.cos(np.radians(65)))
    refused = lap.fit(SortedProfile.of(u, w, PARAMS, toward=over_bottom))
    assert isinstance(refused, NoFit) and "two parts apart" in refused.reason
    for toward in (over_top, None):
        fit = fit_profile(u, w, PARAMS, toward=toward)
        assert fit.kind == LAP
        assert abs(fit.u - corner[0]) < 0.001
