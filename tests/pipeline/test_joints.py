from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from weldseam.config import JointsConfig
from weldseam.pipeline.joints import JointGeometry, JointKind, NoFit, ProfileFit, SortedProfile, fit_profile
from weldseam.pipeline.joints.base import outline_residual

FILLET, SQUARE_BUTT, V_GROOVE = JointKind.FILLET, JointKind.SQUARE_BUTT, JointKind.V_GROOVE
PARAMS = JointsConfig()


def profile(w_of_u, rng, noise=0.0003, half_width=0.025, pitch=0.0004, tilt_rad=0.0):
    u = np.arange(-half_width, half_width, pitch)
    w = w_of_u(u) + rng.normal(0, noise, len(u))
    c, s = np.cos(tilt_rad), np.sin(tilt_rad)
    return c * u - s * w, s * u + c * w


def v_groove(centre, half_open=0.008, depth=0.010):
    return lambda u: -np.clip((half_open - np.abs(u - centre)) * depth / half_open, 0, None)


def test_groove_centre_is_the_middle_of_the_opening(rng):
    u, w = profile(v_groove(0.004), rng)
    fit = fit_profile(u, w, PARAMS)
    assert fit.kind == V_GROOVE
    assert abs(fit.u - 0.004) < 0.0003 and abs(fit.w) < 0.0003
    assert abs(fit.axis_u) < 0.05 and fit.axis_w < -0.99  # perpendicular to the plate, into it


def test_groove_torch_axis_follows_a_tilted_plate(rng):
    u, w = profile(v_groove(0.0), rng, tilt_rad=np.radians(10))
    fit = fit_profile(u, w, PARAMS)
    angle = np.degrees(np.arctan2(fit.axis_u, -fit.axis_w))
    assert fit.kind == V_GROOVE and abs(angle - 10) < 1.5


def test_groove_with_one_hidden_wall_is_still_centred(rng):
    u, w = profile(v_groove(0.0), rng)
    hidden = (u > 0) & (u < 0.008)  # the right wall is not seen
    fit = fit_profile(u[~hidden], w[~hidden], PARAMS)
    assert fit.kind == V_GROOVE and abs(fit.u) < 0.0006


@pytest.mark.parametrize("tilt_deg", [0.0, 25.0])
def test_a_dropout_going_on_past_a_hidden_walls_edge_gives_no_fit_rather_than_a_wider_groove(rng, tilt_deg):
    plate_u, plate_w = profile(v_groove(0.0), rng)
    c, s = np.cos(np.radians(tilt_deg)), np.sin(np.radians(tilt_deg))  # the frame turned against the plate
    u, w = c * plate_u - s * plate_w, s * plate_u + c * plate_w
    for shadow_m in (0.0, 0.001):  # the hidden wall's edge is seen, or 1 mm more is lost: still a fit
        unseen = (plate_u > 0) & (plate_u < 0.008 + shadow_m)
        fit = fit_profile(u[~unseen], w[~unseen], PARAMS)
        assert fit.kind == V_GROOVE and abs(c * fit.u + s * fit.w) < 0.0003 + shadow_m / 2, shadow_m
    unseen = (plate_u > 0) & (plate_u < 0.016)  # the dropout runs 8 mm onto the plate: that edge is not seen
    assert isinstance(fit_profile(u[~unseen], w[~unseen], PARAMS), NoFit)


def test_a_groove_in_depth_quantised_in_1_mm_steps_is_found(rng):
    """Seen square on, a D415's 1 mm depth steps put ~90 % of the flat surface on one level: the
    median deviation is 0, and the next level down must not pass for a depression."""
    errors = []
    for _ in range(40):
        u, w = profile(v_groove(0.002, depth=0.006), rng)
        fit = fit_profile(u, np.round((w - 0.0001) / 0.001) * 0.001 + 0.0001, PARAMS)
        assert fit.kind == V_GROOVE
        errors.append(fit.u - 0.002)
    # A single line of points across 1 mm steps places the edges coarsely (one section in ten is
    # off by 1.5-3 mm); along a seam the sections average out.
    assert abs(np.mean(errors)) < 0.0003 and np.median(np.abs(errors)) < 0.0005


def test_a_noisy_grooves_edges_lie_where_its_walls_leave_the_surface_not_at_their_shallowest_points():
    """Within the surface's noise band (3 sigma) lie a wall's shallowest points too: taken for
    surface, they end it inside the edge and the wall's line is fitted to its lower part only."""
    rng = np.random.default_rng(7)
    errors = []
    for _ in range(200):
        u, w = profile(v_groove(0.0, half_open=0.004, depth=0.006), rng, noise=0.0005)
        fit = fit_profile(u, w, PARAMS, kinds={V_GROOVE})
        errors.append(abs(fit.u))
    assert np.median(errors) < 0.00027  # 0.21 mm; 0.34 when the band's lower tail ended the surface


def oblique_v(rng, noise, view_deg=43.0, half_open=0.004, slope=1.53, mixed=5, pitch=0.0004):
    """(u, w, toward) of a V seen from view_deg off its axis on the -u side: the near wall hidden,
    the far wall seen from where the line of sight over the near rim meets it, and `mixed`
    pixels along that line (a depth edge's mixed pixels); noise in w, a third of it in u."""
    ray = np.array([np.sin(np.radians(view_deg)), -np.cos(np.radians(view_deg))])  # away from the camera
    depth = slope * half_open
    plate = np.arange(-0.025, 0.025, pitch)
    plate = plate[np.abs(plate) >= half_open]
    reach = -2 * depth / (ray[1] - slope * ray[0])  # along the ray from the near rim to the far wall
    wall = np.arange(-half_open + reach * ray[0], half_open, pitch)
    along = rng.uniform(0, reach, mixed)
    u = np.concatenate([plate, wall, -half_open + along * ray[0]])
    w = np.concatenate([np.zeros(len(plate)), -depth + slope * wall, along * ray[1]])
    return u + rng.normal(0, noise / 3, len(u)), w + rng.normal(0, noise, len(u)), (-ray[0], -ray[1])


def test_a_groove_seen_obliquely_with_mixed_pixels_over_its_near_rim_is_found_and_centred():
    rng = np.random.default_rng(7)
    centres = []
    for _ in range(200):
        u, w, toward = oblique_v(rng, 0.0005)
        fit = fit_profile(u, w, PARAMS, kinds={V_GROOVE}, toward=toward)
        if not isinstance(fit, NoFit):
            centres.append(fit.u)
    assert len(centres) >= 170  # 187; 126 when the rim's mixed pixels ended the surface
    assert np.median(np.abs(centres)) < 0.0004


def test_fillet_corner_and_bisector(rng):
    u, w = profile(lambda u: np.abs(u - 0.002), rng)  # 90-degree corner at u = 2 mm
    fit = fit_profile(u, w, PARAMS)
    assert fit.kind == FILLET
    assert abs(fit.u - 0.002) < 0.0005 and abs(fit.w) < 0.0005
    assert abs(fit.axis_u) < 0.05 and fit.axis_w < -0.99


def test_a_fit_seeking_one_joint_finds_that_joint_only(rng):
    corner_u, corner_w = profile(lambda u: np.abs(u - 0.002), rng)
    groove_u, groove_w = profile(v_groove(0.004), rng)
    assert fit_profile(corner_u, corner_w, PARAMS, {FILLET}) == fit_profile(corner_u, corner_w, PARAMS)
    assert isinstance(fit_profile(corner_u, corner_w, PARAMS, {V_GROOVE}), NoFit)
    assert fit_profile(groove_u, groove_w, PARAMS, {V_GROOVE}) == fit_profile(groove_u, groove_w, PARAMS)
    found = fit_profile(groove_u, groove_w, PARAMS, {FILLET})
    assert isinstance(found, NoFit) or found.kind == FILLET


def test_a_step_a_convex_edge_and_a_plane_are_not_seams(rng):
    for shape in (lambda u: np.where(u > 0, 0.008, 0.0), lambda u: -np.abs(u), lambda u: 0 * u):
        u, w = profile(shape, rng)
        assert isinstance(fit_profile(u, w, PARAMS), NoFit)


def test_groove_centre_is_unbiased_on_noisy_symmetric_profiles():
    rng = np.random.default_rng(0)
    centres = []
    for _ in range(200):
        u = rng.uniform(-0.025, 0.025, 125)
        w = v_groove(0.0)(u) + rng.normal(0, 0.0005, len(u))
        fit = fit_profile(u, w, PARAMS)
        centres.append(fit.u)
    assert abs(np.mean(centres)) < 0.15e-3  # scatter ~0.6 mm, so the mean's own noise is ~0.05 mm


def test_one_face_beside_a_hole_is_not_a_fillet(rng):
    # A flange seen obliquely up to the shadow a web casts: one tilted face, then no data
    # but one stray point 18 mm away. The stray point and the face's last few points must
    # not pass for a second face (the old leg measure saw a 20 mm leg there).
    for _ in range(20):
        u = np.arange(-0.022, 0.0005, 0.0007)
        w = -0.45 * u + rng.normal(0, 0.0005, len(u))
        assert isinstance(fit_profile(np.append(u, 0.0185), np.append(w, 0.0084), PARAMS), NoFit)


def test_a_hole_with_vertical_walls_is_not_a_groove(rng):
    # Looking down into a through-hole: surface, nothing (vertical walls), the table far
    # below, nothing, surface.
    u = np.arange(-0.025, 0.025, 0.0005)
    w = np.where(np.abs(u) < 0.006, -0.012, 0.0) + rng.normal(0, 0.0003, len(u))
    seen = (np.abs(u) < 0.004) | (np.abs(u) > 0.008)
    assert isinstance(fit_profile(u[seen], w[seen], PARAMS), NoFit)




def square_gap(u, w, centre, gap, floor=None):
    """A square butt's profile: the points over the gap (|u - centre| < gap / 2) are not seen, or
    (floor, m below the surface) are seen on the table under it."""
    over = np.abs(u - centre) < gap / 2
    if floor is None:
        return u[~over], w[~over]
    return u, np.where(over, w - floor, w)


@pytest.mark.parametrize("gap_mm", [1.0, 2.0, 3.0])
def test_square_butt_centre_is_the_middle_of_the_gap(rng, gap_mm):
    for floor in (None, 0.006):  # a dropout along the gap, or the table seen through it
        u, w = square_gap(*profile(lambda u: 0 * u, rng), 0.0007, gap_mm / 1000, floor)
        fit = fit_profile(u, w, PARAMS)
        assert fit.kind == SQUARE_BUTT and abs(fit.u - 0.0007) < 0.0003 and abs(fit.w) < 0.0003
        assert abs(fit.geometry.opening_m - gap_mm / 1000) < 0.0006
        assert abs(fit.axis_u) < 0.05 and fit.axis_w < -0.99


def test_square_butt_torch_axis_is_perpendicular_to_tilted_plates(rng):
    c, s = np.cos(np.radians(12)), np.sin(np.radians(12))
    plate_u, plate_w = square_gap(*profile(lambda u: 0 * u, rng), 0.0, 0.0015)
    u, w = c * plate_u - s * plate_w, s * plate_u + c * plate_w
    fit = fit_profile(u, w, PARAMS)
    assert fit.kind == SQUARE_BUTT and abs(np.degrees(np.arctan2(fit.axis_u, -fit.axis_w)) - 12) < 1.5
    assert abs(c * fit.u + s * fit.w) < 0.0003  # the seam point back on the plates is the gap's centre


def test_what_looks_like_a_gap_but_is_not_a_square_butt(rng):
    plate = profile(lambda u: 0 * u, rng, pitch=0.0007)
    assert isinstance(fit_profile(*plate, PARAMS, {SQUARE_BUTT}), NoFit)  # sampling leaves no opening
    too_wide = square_gap(*plate, 0.0, 0.005)
    assert isinstance(fit_profile(*too_wide, PARAMS, {SQUARE_BUTT}), NoFit)
    u, w = profile(lambda u: np.where(u > 0, -0.003, 0.0), rng)  # a step with a strip unseen at its edge
    assert isinstance(fit_profile(*square_gap(u, w, 0.0, 0.0015), PARAMS, {SQUARE_BUTT}), NoFit)
    u, w = profile(lambda u: np.where(u > 0, 0.4 * u, 0.0), rng)  # a bend with a strip unseen
    assert isinstance(fit_profile(*square_gap(u, w, 0.0, 0.0015), PARAMS, {SQUARE_BUTT}), NoFit)
    u, w = profile(lambda u: np.where(u > 0, 0.0, np.nan), rng)  # a plate's edge: one side only
    assert isinstance(fit_profile(*square_gap(u[w == w], w[w == w], 0.0, 0.0015), PARAMS, {SQUARE_BUTT}), NoFit)
    u, w = square_gap(*plate, 0.0, 0.0015)
    bead = np.abs(u) < 0.003  # something standing over the gap (a bead, a tack): no opening
    assert isinstance(fit_profile(u, np.where(bead, w + 0.002, w), PARAMS, {SQUARE_BUTT}), NoFit)


def test_a_square_gap_is_found_where_the_pitch_is_as_wide_as_the_gap_but_not_elsewhere():
    """One pixel lattice leaves openings of one pitch (+ noise) between neighbours everywhere:
    a gap must stand out of them."""
    rng = np.random.default_rng(3)
    found = missed = 0
    for _ in range(40):
        u = np.arange(-0.025, 0.025, 0.0008) + rng.normal(0, 0.00008, 63)
        w = rng.normal(0, 0.0003, len(u))
        missed += isinstance(fit_profile(u, w, PARAMS, {SQUARE_BUTT}), NoFit)
        fit = fit_profile(*square_gap(u, w, 0.0, 0.0015), PARAMS, {SQUARE_BUTT})
        found += isinstance(fit, ProfileFit) and abs(fit.u) < 0.0006
    assert missed == 40 and found >= 36


def test_an_opening_the_image_shows_need_not_stand_out_of_the_lattice():
    """Where the sensor's image shows a gap (a line of pixels that returned nothing), an opening
    there only as wide as the widest of the lattice's own is the gap; without it, or with it
    elsewhere, it is not."""
    rng = np.random.default_rng(4)
    shown = unshown = elsewhere = 0
    for _ in range(30):  # a 0.8 mm gap in a 1 mm lattice jittered by 0.25 mm
        u = np.sort(np.arange(-0.025, 0.025, 0.001) + rng.normal(0, 0.00025, 50))
        u, w = square_gap(u, rng.normal(0, 0.0003, len(u)), 0.0, 0.0008)
        unshown += isinstance(fit_profile(u, w, PARAMS, {SQUARE_BUTT}), ProfileFit)
        elsewhere += isinstance(fit_profile(u, w, PARAMS, {SQUARE_BUTT}, np.array([0.006])), ProfileFit)
        fit = fit_profile(u, w, PARAMS, {SQUARE_BUTT}, np.array([-0.0002, 0.0003]))
        shown += isinstance(fit, ProfileFit) and abs(fit.u) < 0.0005
    assert shown >= 18 and unshown <= 10 and elsewhere == unshown


def test_a_gaps_centre_is_where_the_image_crosses_it_unless_its_far_wall_was_seen():
    """Pixels straddling a gap's rim return a depth between the plate's and the floor's: those
    over one rim lie within the surface's noise band and narrow the cloud's opening from that
    side, so its middle moves off the gap. The image's crossings (the middles between the pixels
    either side of the gap) centre it. Where the far wall was seen through the gap, a crossing
    ends on the wall's points that noise brought nearer the camera, off toward it: the opening's
    rims centre it."""
    rng = np.random.default_rng(11)
    crossed, uncrossed, walled = [], [], []
    for _ in range(30):  # a 1.2 mm gap at u = 0 in a 0.7 mm lattice; its left rim's pixels mixed
        u = np.sort(np.arange(-0.025, 0.025, 0.0007) + rng.normal(0, 0.0001, 72))
        w = rng.normal(0, 0.0003, len(u))
        mixed = (u > -0.0006) & (u < 0.0001)
        keep = (np.abs(u) >= 0.0006) | mixed
        gap_u, gap_w = u[keep], np.where(mixed, w - 0.0005, w)[keep]
        crossings = rng.normal(0, 0.0001, 3)
        fit = fit_profile(gap_u, gap_w, PARAMS, {SQUARE_BUTT}, crossings)
        crossed.append(fit.u if isinstance(fit, ProfileFit) else np.nan)
        fit = fit_profile(gap_u, gap_w, PARAMS, {SQUARE_BUTT})
        uncrossed.append(fit.u if isinstance(fit, ProfileFit) else np.nan)
        # A 3 mm gap seen from the right, 30 degrees off: its far (left) wall down to 4 mm, spread
        # 1 mm toward the camera by range noise; the crossings off toward the camera.
        plates = np.abs(u) >= 0.0015
        wall_w = -rng.uniform(0.002, 0.004, 6)
        wall_u = -0.0015 + rng.uniform(0.0, 0.001, 6)
        order = np.argsort(np.r_[u[plates], wall_u])
        fit = fit_profile(np.r_[u[plates], wall_u][order], np.r_[w[plates], wall_w][order], PARAMS, {SQUARE_BUTT},
                          0.0006 + rng.normal(0, 0.0002, 3))  # fmt: skip
        walled.append(fit.u if isinstance(fit, ProfileFit) else np.nan)
    assert np.count_nonzero(np.isfinite(crossed)) >= 24 and np.nanmedian(np.abs(crossed)) < 0.00015
    assert np.nanmedian(uncrossed) > 0.00015  # the cloud's opening alone: off toward the unmixed rim
    assert np.count_nonzero(np.isfinite(walled)) >= 24 and np.nanmedian(np.abs(walled)) < 0.0003


def test_where_the_lattice_hides_the_gap_the_opening_most_image_openings_lie_in_is_it():
    """A 0.5 mm gap in a 0.4 mm lattice jittered by 0.2 mm (a 1 mm voxel cloud's section) is rarely
    the widest opening there. Most of the section's image openings lying in it make it the gap;
    image openings scattered over the section's other openings add nothing."""
    rng = np.random.default_rng(7)
    concentrated = alone = scattered = 0
    for _ in range(30):
        u = np.sort(np.arange(-0.025, 0.025, 0.0004)[:125] + rng.normal(0, 0.0002, 125))
        u, w = square_gap(u, rng.normal(0, 0.0003, len(u)), 0.0, 0.0005)
        fit = fit_profile(u, w, PARAMS, {SQUARE_BUTT})
        alone += isinstance(fit, ProfileFit) and abs(fit.u) < 0.0006
        fit = fit_profile(u, w, PARAMS, {SQUARE_BUTT}, np.array([-0.02, -0.011, 0.007, 0.018]))
        scattered += isinstance(fit, ProfileFit) and abs(fit.u) < 0.0006
        fit = fit_profile(u, w, PARAMS, {SQUARE_BUTT}, np.array([-0.0001, 0.0001, 0.0002, 0.009]))
        concentrated += isinstance(fit, ProfileFit) and abs(fit.u) < 0.0006
    assert concentrated >= 27 and alone <= 10 and scattered <= alone


def oblique_square_gap(rng, gap):
    """A square butt seen obliquely: the plates' surface (w = 0) with the gap |u| < gap / 2 unseen,
    and its far wall (u = gap / 2) seen from the surface 4 mm down, the near wall hidden."""
    u = np.arange(-0.025, 0.025, 0.0006) + rng.normal(0, 0.00005, 84)
    w = rng.normal(0, 0.0003, len(u))
    outside = np.abs(u) >= gap / 2
    wall_w = np.arange(-0.0003, -0.004, -0.0005)
    u, w = np.r_[u[outside], gap / 2 + rng.normal(0, 0.0001, len(wall_w))], np.r_[w[outside], wall_w]
    order = np.argsort(u)
    return u[order], w[order]


def test_a_square_gap_with_one_wall_seen_is_a_square_butt_not_a_bevel_or_v():
    """One square wall seen and the surface ending across the gap: a bevel or a V with a hidden wall
    draws the same outline, but measured no flank; the square butt is the joint, at the gap's centre."""
    rng = np.random.default_rng(5)
    found = 0
    for gap in (0.0012, 0.002, 0.003):
        for _ in range(20):
            fit = fit_profile(*oblique_square_gap(rng, gap), PARAMS)
            found += fit.kind == SQUARE_BUTT and abs(fit.u) < 0.0004
    assert found >= 0.6 * 60  # without the rule 40 %: the bevel with its wall hidden won


@pytest.mark.parametrize("included_deg, ratio, expected", [
    (None, 1.1, SQUARE_BUTT),  # no flank measured, as close: the square opening
    (None, 1.3, V_GROOVE),  # no flank measured, but the square butt's outline clearly farther
    (60.0, 1.1, V_GROOVE),  # a flank measured: the groove
])
def test_a_square_butt_wins_over_a_groove_that_measured_no_flank(monkeypatch, rng, included_deg, ratio, expected):
    import weldseam.pipeline.joints as joints

    u, w = profile(lambda u: 0 * u, rng, noise=0.0)

    def model(kind, offset_m, geometry):
        def fit(profile):
            outline = ((-1.0, offset_m), (1.0, offset_m))  # a line offset_m over the plate
            return ProfileFit(kind, 0.0, 0.0, 0.0, -1.0, 0.0, geometry, outline)
        return SimpleNamespace(KIND=kind, CENTRED=True, SPECIALISES=None, fit=fit)

    groove = model(V_GROOVE, 0.0005, JointGeometry(opening_m=0.002, included_deg=included_deg))
    square = model(SQUARE_BUTT, 0.0005 * ratio, JointGeometry(opening_m=0.002))
    monkeypatch.setattr(joints, "MODELS", (groove, square))
    assert joints.fit_profile(u, w, PARAMS).kind == expected


def test_a_gap_whose_far_wall_is_seen_beside_its_rim_need_not_be_wider_than_the_lattice_spacing():
    """Seen obliquely, a gap's far wall stands at its rim, and voxels merge the wall's top into
    the surface: its deeper points lie just beyond the rim. An opening with them is a gap when it
    is the widest there; one with nothing seen must stand out of the lattice's own spacing."""
    rng = np.random.default_rng(4)
    seen = unseen = 0
    for _ in range(40):
        u = np.arange(-0.025, 0.025, 0.0008) + rng.normal(0, 0.00015, 63)  # a noisy voxel lattice
        w = rng.normal(0, 0.0003, len(u))
        u, w = square_gap(u, w, 0.0, 0.0006)
        fit = fit_profile(u, w, PARAMS, {SQUARE_BUTT})
        unseen += isinstance(fit, ProfileFit) and abs(fit.u) < 0.0006
        wall_u, wall_w = 0.0005 + rng.uniform(0, 0.0008, 3), -np.array([0.002, 0.003, 0.004])
        order = np.argsort(np.r_[u, wall_u])
        fit = fit_profile(np.r_[u, wall_u][order], np.r_[w, wall_w][order], PARAMS, {SQUARE_BUTT})
        seen += isinstance(fit, ProfileFit) and abs(fit.u) < 0.0006
    assert seen >= 24 and unseen <= seen - 8  # counting only what lies between the rims: 18 and 16


def test_a_models_outline_residual_is_the_median_distance_of_the_points_around_its_seam():
    u = np.linspace(-0.02, 0.02, 401)
    corner = np.abs(u)  # a 90-degree corner at the origin
    outline = ((-1.0, 1.0), (0.0, 0.0), (1.0, 1.0))
    assert outline_residual(u, corner, outline, 0.0, 0.012) < 1e-12
    assert abs(outline_residual(u, corner + 0.001, outline, 0.0, 0.012) - 0.001 / np.sqrt(2)) < 1e-6
    flat = ((-1.0, 0.0), (1.0, 0.0))  # a plane through the corner explains it worse
    assert outline_residual(u, corner, flat, 0.0, 0.012) > 0.004


def test_of_the_models_that_fit_the_closest_outline_wins_whatever_their_order(monkeypatch, rng):
    import weldseam.pipeline.joints as joints

    u, w = profile(lambda u: np.abs(u - 0.002), rng)  # a corner at u = 2 mm

    def model(kind, corner_u):
        def fit(profile):
            outline = ((corner_u - 1.0, 1.0), (corner_u, 0.0), (corner_u + 1.0, 1.0))
            return ProfileFit(kind, corner_u, 0.0, 0.0, -1.0, 0.0, JointGeometry(), outline)
        return SimpleNamespace(KIND=kind, CENTRED=False, SPECIALISES=None, fit=fit)

    near, far = model(FILLET, 0.002), model(V_GROOVE, 0.006)
    for models in ((near, far), (far, near)):
        monkeypatch.setattr(joints, "MODELS", models)
        found = joints.fit_profile(u, w, PARAMS)
        assert found.kind == FILLET and found.residual_m < 0.0005


def test_a_fit_whose_outline_lies_far_from_the_points_is_no_fit(monkeypatch, rng):
    # A model that 'fits' a corner 6 mm off the section's one (a few points of something else):
    # alone, it must not become the joint; the section says why.
    import weldseam.pipeline.joints as joints

    u, w = profile(lambda u: np.abs(u - 0.002), rng)

    def fit(profile):
        outline = ((0.008 - 1.0, 1.0), (0.008, 0.0), (0.008 + 1.0, 1.0))
        return ProfileFit(FILLET, 0.008, 0.0, 0.0, -1.0, 0.0, JointGeometry(), outline)

    monkeypatch.setattr(joints, "MODELS", (SimpleNamespace(KIND=FILLET, CENTRED=False, SPECIALISES=None, fit=fit),))
    found = joints.fit_profile(u, w, PARAMS)
    assert isinstance(found, NoFit) and "outline lies" in found.reason


def test_the_surface_line_is_computed_once_per_profile(rng):
    """The V-groove, bevel and square butt models read one surface line per profile: the same
    profile gives the very same (read-only) result, another profile of equal points its own,
    and a deeper least groove ignores more points below the line."""
    u, w = profile(v_groove(0.001), rng)
    shallow = SortedProfile.of(u, w, PARAMS)
    first = shallow.surface
    assert shallow.surface is first
    assert not first.on_surface.flags.writeable and not first.residual.flags.writeable
    again = SortedProfile.of(u.copy(), w.copy(), PARAMS).surface
    assert again is not first and all(np.array_equal(a, b) for a, b in zip(again, first))
    deep = SortedProfile.of(u, w, replace(PARAMS, groove_min_depth_m=0.004)).surface
    assert deep.depth_limit > first.depth_limit
    # The groove (8 mm half-opening at u = 1 mm) lies below the line, the plate beside it on it.
    assert not first.on_surface[np.abs(shallow.u - 0.001) < 0.004].any()
    assert first.on_surface[np.abs(shallow.u - 0.001) > 0.012].mean() > 0.9


def test_a_lattice_too_sparse_to_resolve_a_gap_takes_no_image_opening_for_one():
    """Far off or grazing, the fine cloud's points lie 1.5 mm apart: an opening one step wide that
    the image's openings fall in is the lattice's, not a gap."""
    rng = np.random.default_rng(8)
    alone = shown = 0
    for _ in range(30):
        u = np.sort(np.arange(-0.025, 0.025, 0.0015) + rng.normal(0, 0.0002, 34))
        w = rng.normal(0, 0.0002, len(u))
        alone += isinstance(fit_profile(u, w, PARAMS, {SQUARE_BUTT}), ProfileFit)
        shown += isinstance(fit_profile(u, w, PARAMS, {SQUARE_BUTT}, np.array([-0.0001, 0.0001, 0.0002])), ProfileFit)
    assert shown - alone <= 2  # without the step rule, all 30


def test_a_gap_the_cloud_narrows_below_the_narrowest_opening_is_found_where_the_image_crosses_it():
    """A 1 mm gap seen from 0.45 m (0.7 mm pixels): the pixels over its rims see plate, so the cloud's
    opening is 0.3-0.45 mm, under joints.gap_min_m. The image's crossings of the gap, together near
    the centre, find it where the opening is wider than the lattice's step; crossings spread over
    3 mm (a dropout's blob) add nothing to what the cloud alone finds (its opening reaches
    joints.gap_min_m in a few draws)."""
    rng = np.random.default_rng(5)
    shown = unshown = blob = 0
    for _ in range(30):
        u = np.arange(-0.025, 0.025, 0.00015)
        u = np.sort(u + rng.normal(0, 0.00003, len(u)))
        plate_w = rng.normal(0, 0.0003, len(u))
        u_gap, w_gap = square_gap(u, plate_w, 0.0004, 0.0003)
        fit = fit_profile(u_gap, w_gap, PARAMS, {SQUARE_BUTT}, np.array([0.0003, 0.0004, 0.0005]))
        shown += isinstance(fit, ProfileFit) and abs(fit.u - 0.0004) < 0.0002
        unshown += isinstance(fit_profile(u_gap, w_gap, PARAMS, {SQUARE_BUTT}), ProfileFit)
        blob += isinstance(fit_profile(u_gap, w_gap, PARAMS, {SQUARE_BUTT}, np.array([-0.0025, -0.001, 0.0004])),
                           ProfileFit)
    assert shown >= 27 and unshown <= 10 and blob <= unshown
