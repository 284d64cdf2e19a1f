"""The single bevel model against analytic profiles: a square-edged plate at u < -gap/2 and a plate
bevelled bevel_deg from its normal above a root face, the surface at w = 0. The seam is the
middle of the opening at the surface, the torch axis perpendicular to the plates."""

import numpy as np
import pytest

from tests.pipeline.test_joints import profile, v_groove
from weldseam.config import JointsConfig
from weldseam.pipeline.joints import JointKind, NoFit, SortedProfile, bevel, fit_profile

BEVEL, V_GROOVE = JointKind.BEVEL, JointKind.V_GROOVE
PARAMS = JointsConfig()


def bevel_profile(rng, *, thickness=0.008, bevel_deg=40.0, gap=0.001, root_face=0.001, noise=0.0002, pitch=0.0005,
                  square_seen=False, bevel_seen=True, mirrored=False, tilt_deg=0.0):
    """(u, w, seam (u, w), torch axis (u, w)) across a single bevel: nothing seen through the
    root gap, the square wall seen or not, the bevel seen or not (grazing); `mirrored`: the
    bevel on the left; the whole turned by `tilt_deg`."""
    top = gap / 2 + (thickness - root_face) * np.tan(np.radians(bevel_deg))  # the bevel's top edge
    u = np.arange(-0.025, 0.025, pitch) + rng.uniform(0.0, pitch)
    on_bevel = (u > gap / 2) & (u < top)
    w = np.where(on_bevel, -(thickness - root_face) + (u - gap / 2) / np.tan(np.radians(bevel_deg)), 0.0)
    seen = (np.abs(u) > gap / 2) & (bevel_seen | ~on_bevel)
    u, w = u[seen], w[seen]
    if square_seen:
        wall = np.arange(-thickness + root_face, 0.0, pitch)
        u, w = np.append(u, np.full(len(wall), -gap / 2)), np.append(w, wall)
    w = w + rng.normal(0.0, noise, len(w))
    u = -u if mirrored else u
    turn = np.radians(tilt_deg)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    points = np.column_stack([u, w]) @ rotation.T
    order = np.argsort(points[:, 0])
    seam_u = (top - gap / 2) / 2 * (-1 if mirrored else 1)
    return points[order, 0], points[order, 1], rotation @ [seam_u, 0.0], rotation @ [0.0, -1.0]


@pytest.mark.parametrize("shape", [
    {}, {"mirrored": True}, {"square_seen": True}, {"square_seen": True, "bevel_seen": False},
    {"square_seen": True, "bevel_seen": False, "tilt_deg": 17.0, "mirrored": True}, {"tilt_deg": -12.0},
    {"bevel_deg": 30.0, "gap": 0.002}, {"bevel_deg": 50.0, "gap": 0.0, "root_face": 0.0},
])
def test_the_seam_is_the_middle_of_the_opening_and_the_torch_perpendicular_to_the_plates(rng, shape):
    offsets, angles, kinds = [], [], []
    for _ in range(20):
        u, w, seam, axis = bevel_profile(rng, **shape)
        fit = bevel.fit(SortedProfile.of(u, w, PARAMS))
        offsets.append((fit.u - seam[0], fit.w - seam[1]))
        angles.append(np.degrees(np.arccos(np.clip(fit.axis_u * axis[0] + fit.axis_w * axis[1], -1.0, 1.0))))
        kinds.append(fit_profile(u, w, PARAMS).kind)
    assert np.hypot(*np.mean(offsets, axis=0)) < 0.0001 and max(angles) < 1.0
    assert kinds.count(BEVEL) >= 18  # of the models, the bevel explains it


def test_noisy_sparse_and_quantised_bevels_are_centred(rng):
    offsets = []
    for _ in range(20):
        u, w, seam, _ = bevel_profile(rng, noise=0.0005, pitch=0.001, tilt_deg=6.0)
        quantised = np.round((w - 0.0001) / 0.001) * 0.001 + 0.0001
        for fit in (bevel.fit(SortedProfile.of(u, w, PARAMS)), bevel.fit(SortedProfile.of(u, quantised, PARAMS))):
            if not isinstance(fit, NoFit):
                offsets.append(fit.u - seam[0])
    assert len(offsets) >= 20 and abs(np.mean(offsets)) < 0.0003


def test_a_bevel_whose_walls_top_is_lost_in_the_noise_is_still_found_and_centred(rng):
    """In 0.7 mm of noise the surface takes in what lies within 3 sigma (2.1 mm) below it: the
    top of a 50-degree bevel wall, whose last surface point then lies ~2.5 mm inside its edge. The
    wall's own line still finds that edge, and the seam is the middle of the opening."""
    offsets = []
    for _ in range(30):
        u, w, seam, _ = bevel_profile(rng, noise=0.0007, pitch=0.0008, bevel_deg=50.0, square_seen=True)
        fit = bevel.fit(SortedProfile.of(u, w, PARAMS))
        if not isinstance(fit, NoFit):
            offsets.append(fit.u - seam[0])
    assert len(offsets) >= 6 and abs(np.mean(offsets)) < 0.0003


def test_the_bevel_model_centres_a_bevel_the_v_groove_model_pulls_toward_the_bevel(rng):
    """The V-groove model assumes mirrored walls: where the square wall is seen, its seam falls
    off the opening's middle; the bevel model explains the section better and is chosen."""
    v_offsets, offsets = [], []
    for _ in range(20):
        u, w, seam, _ = bevel_profile(rng, square_seen=True, bevel_deg=45.0)
        found = fit_profile(u, w, PARAMS, {V_GROOVE})
        if not isinstance(found, NoFit):
            v_offsets.append(abs(found.u - seam[0]))
        offsets.append(abs(fit_profile(u, w, PARAMS).u - seam[0]))
    assert np.mean(offsets) < 0.0001 < np.mean(v_offsets) if v_offsets else np.mean(offsets) < 0.0001


@pytest.mark.parametrize("hidden_wall", [0, 1])
def test_a_v_groove_stays_a_v_groove_even_with_one_wall_hidden(rng, hidden_wall):
    u, w = profile(v_groove(0.0), rng)
    if hidden_wall:
        keep = ~((u > 0) & (u < 0.008))
        u, w = u[keep], w[keep]
    assert fit_profile(u, w, PARAMS).kind == V_GROOVE


@pytest.mark.parametrize("shape", [
    lambda u: 0.0 * u,  # a plane
    lambda u: np.where(np.abs(u) < 0.004, -0.006, 0.0),  # a slot: two square walls, no bevel
    lambda u: np.abs(u) * 0.6,  # a concave corner
])
def test_what_is_not_a_bevel_gives_no_bevel(rng, shape):
    u = np.arange(-0.025, 0.025, 0.0005)
    w = shape(u) + rng.normal(0.0, 0.0002, len(u))
    assert isinstance(bevel.fit(SortedProfile.of(u, w, PARAMS)), NoFit)


def test_a_bevel_wall_in_depth_steps_is_one_wall_at_the_plates_noise():
    """Depth in steps: of a wall's points most lie on its line and the rest a step (0.6 mm) off,
    so their median deviation is ~0 and a band of 3 of their own sigma would take only the first.
    The plate surface beside it, seen by the same sensor, says how noisy the wall is."""
    x = np.linspace(-0.0014, 0.0025, 17)
    steps = np.array([0, 0, 0, 0, -1, 1, 1, 0, 0, -1, 1, 0, 0, 0, -1, -1, 1]) * 0.0006
    depth = 0.004 + 1.06 * x + steps
    wall = bevel._bevel_wall(x, depth, 1.0, surface_sigma=0.0003)
    assert wall is not None
    edge, slope, _, _ = wall
    assert abs(edge + 0.004 / 1.06) < 0.0003 and abs(slope - 1.06) < 0.1
    assert bevel._bevel_wall(x, depth, 1.0, surface_sigma=0.0) is None, "its own noise alone: half of it off the line"


@pytest.mark.parametrize("square_seen", [False, True])
def test_a_bevel_seen_from_far_is_found_in_most_sections_and_centred(rng, square_seen):
    """At ~0.55 m (0.9 mm of noise) the surface's band takes the wall's top 2.7 mm. The wall's
    points chosen by depth (deeper than that band) keep, near its top, only those noise pushed
    down: the line comes out flatter and its edge beyond the surface's end, so the section was
    refused as no bevel in most draws (measured: 73 and 78 of 200 found, half of them 0.35-0.46 mm
    or more off). Chosen by position, the line keeps its slope (103 and 109 found, 0.19-0.21 mm)."""
    offsets, draws = [], 200
    for _ in range(draws):
        u, w, seam, _ = bevel_profile(rng, noise=0.0009, pitch=0.0006, bevel_deg=45.0, square_seen=square_seen)
        fit = bevel.fit(SortedProfile.of(u, w, PARAMS))
        if not isinstance(fit, NoFit):
            offsets.append(fit.u - seam[0])
    assert len(offsets) >= 0.45 * draws and np.median(np.abs(offsets)) < 0.0003


def test_a_square_wall_stands_square_and_a_v_grooves_wall_near_its_edge_is_none(rng):
    """Near its edge a V-groove's wall (38 degrees off the plate normal) puts 1-2 mm of depth within
    SQUARE_WALL_M of one place, as a square wall does (a narrow V seen from above at 0.3 m, broad
    y_groove 156, then had most sections named bevels and two branches untraced); it leans along
    the surface as it goes down (0.8 m per m), a square wall does not (its points spread by the
    noise only: 0.2 mm across 1.8 mm of depth reads a lean past 15 degrees in ~5 % of draws)."""
    depth = np.linspace(0.0017, 0.0035, 7)
    kept = refused = 0
    for _ in range(100):
        square = -0.0015 + rng.normal(0.0, 0.0002, len(depth))
        kept += bevel._square_wall(square, depth) is not None
        sloped = -0.0022 + np.tan(np.radians(38.0)) * (depth - depth[0]) + rng.normal(0.0, 0.0002, len(depth))
        refused += bevel._square_wall(sloped, depth) is None
    assert kept >= 88 and refused >= 95
