import numpy as np
import pytest
from scipy.spatial import cKDTree

from weldseam.config import SectionConfig
from weldseam.geometry import unit
from weldseam.pipeline.condition import condition_points
from weldseam.pipeline.section import (
    FILLET,
    V_GROOVE,
    GrooveTemplate,
    analyse_sections,
    bridge_groove,
    fit_profile,
    fit_section,
    groove_bottom,
    groove_template,
    section_params,
    sees_past_end,
)
from weldseam.synthetic.scenes import FAMILIES, make_scan

PARAMS = dict(face_radius_m=0.012, groove_min_depth_m=0.0015, fillet_min_leg_m=0.012)


def profile(w_of_u, rng, noise=0.0003, half_width=0.025, pitch=0.0004, tilt_rad=0.0):
    u = np.arange(-half_width, half_width, pitch)
    w = w_of_u(u) + rng.normal(0, noise, len(u))
    c, s = np.cos(tilt_rad), np.sin(tilt_rad)
    return c * u - s * w, s * u + c * w


def v_groove(centre, half_open=0.008, depth=0.010):
    return lambda u: -np.clip((half_open - np.abs(u - centre)) * depth / half_open, 0, None)


def test_groove_centre_is_the_middle_of_the_opening(rng):
    u, w = profile(v_groove(0.004), rng)
    fit = fit_profile(u, w, **PARAMS)
    assert fit.joint == V_GROOVE
    assert abs(fit.u - 0.004) < 0.0003 and abs(fit.w) < 0.0003
    assert abs(fit.axis_u) < 0.05 and fit.axis_w < -0.99  # perpendicular to the plate, into it


def test_groove_torch_axis_follows_a_tilted_plate(rng):
    u, w = profile(v_groove(0.0), rng, tilt_rad=np.radians(10))
    fit = fit_profile(u, w, **PARAMS)
    angle = np.degrees(np.arctan2(fit.axis_u, -fit.axis_w))
    assert fit.joint == V_GROOVE and abs(angle - 10) < 1.5


def test_groove_with_one_hidden_wall_is_still_centred(rng):
    u, w = profile(v_groove(0.0), rng)
    hidden = (u > 0) & (u < 0.008)  # the right wall is not seen
    fit = fit_profile(u[~hidden], w[~hidden], **PARAMS)
    assert fit.joint == V_GROOVE and abs(fit.u) < 0.0006


@pytest.mark.parametrize("tilt_deg", [0.0, 25.0])
def test_a_dropout_going_on_past_a_hidden_walls_edge_gives_no_fit_rather_than_a_wider_groove(rng, tilt_deg):
    plate_u, plate_w = profile(v_groove(0.0), rng)
    c, s = np.cos(np.radians(tilt_deg)), np.sin(np.radians(tilt_deg))  # the frame turned against the plate
    u, w = c * plate_u - s * plate_w, s * plate_u + c * plate_w
    for shadow_m in (0.0, 0.001):  # the hidden wall's edge is seen, or 1 mm more is lost: still a fit
        unseen = (plate_u > 0) & (plate_u < 0.008 + shadow_m)
        fit = fit_profile(u[~unseen], w[~unseen], **PARAMS)
        assert fit.joint == V_GROOVE and abs(c * fit.u + s * fit.w) < 0.0003 + shadow_m / 2, shadow_m
    unseen = (plate_u > 0) & (plate_u < 0.016)  # the dropout runs 8 mm onto the plate: that edge is not seen
    assert fit_profile(u[~unseen], w[~unseen], **PARAMS) is None


def test_a_groove_in_depth_quantised_in_1_mm_steps_is_found(rng):
    """Seen square on, a D415's 1 mm depth steps put ~90 % of the flat surface on one level: the
    median deviation is 0, and the next level down must not pass for a depression."""
    errors = []
    for _ in range(40):
        u, w = profile(v_groove(0.002, depth=0.006), rng)
        fit = fit_profile(u, np.round((w - 0.0001) / 0.001) * 0.001 + 0.0001, **PARAMS)
        assert fit is not None and fit.joint == V_GROOVE
        errors.append(fit.u - 0.002)
    # A single line of points across 1 mm steps places the edges coarsely (one section in ten is
    # off by 1.5-3 mm); along a seam the sections average out.
    assert abs(np.mean(errors)) < 0.0003 and np.median(np.abs(errors)) < 0.0005


def test_fillet_corner_and_bisector(rng):
    u, w = profile(lambda u: np.abs(u - 0.002), rng)  # 90-degree corner at u = 2 mm
    fit = fit_profile(u, w, **PARAMS)
    assert fit.joint == FILLET
    assert abs(fit.u - 0.002) < 0.0005 and abs(fit.w) < 0.0005
    assert abs(fit.axis_u) < 0.05 and fit.axis_w < -0.99


def test_a_fit_seeking_one_joint_finds_that_joint_only(rng):
    corner_u, corner_w = profile(lambda u: np.abs(u - 0.002), rng)
    groove_u, groove_w = profile(v_groove(0.004), rng)
    assert fit_profile(corner_u, corner_w, **PARAMS, joint=FILLET) == fit_profile(corner_u, corner_w, **PARAMS)
    assert fit_profile(corner_u, corner_w, **PARAMS, joint=V_GROOVE) is None
    assert fit_profile(groove_u, groove_w, **PARAMS, joint=V_GROOVE) == fit_profile(groove_u, groove_w, **PARAMS)
    found = fit_profile(groove_u, groove_w, **PARAMS, joint=FILLET)
    assert found is None or found.joint == FILLET


def test_a_step_a_convex_edge_and_a_plane_are_not_seams(rng):
    for shape in (lambda u: np.where(u > 0, 0.008, 0.0), lambda u: -np.abs(u), lambda u: 0 * u):
        u, w = profile(shape, rng)
        assert fit_profile(u, w, **PARAMS) is None


def test_groove_centre_is_unbiased_on_noisy_symmetric_profiles():
    rng = np.random.default_rng(0)
    centres = []
    for _ in range(200):
        u = rng.uniform(-0.025, 0.025, 125)
        w = v_groove(0.0)(u) + rng.normal(0, 0.0005, len(u))
        fit = fit_profile(u, w, **PARAMS)
        centres.append(fit.u)
    assert abs(np.mean(centres)) < 0.15e-3  # scatter ~0.6 mm, so the mean's own noise is ~0.05 mm


def test_one_face_beside_a_hole_is_not_a_fillet(rng):
    # A flange seen obliquely up to the shadow a web casts: one tilted face, then no data
    # but one stray point 18 mm away. The stray point and the face's last few points must
    # not pass for a second face (the old leg measure saw a 20 mm leg there).
    for _ in range(20):
        u = np.arange(-0.022, 0.0005, 0.0007)
        w = -0.45 * u + rng.normal(0, 0.0005, len(u))
        assert fit_profile(np.append(u, 0.0185), np.append(w, 0.0084), **PARAMS) is None


def test_a_hole_with_vertical_walls_is_not_a_groove(rng):
    # Looking down into a through-hole: surface, nothing (vertical walls), the table far
    # below, nothing, surface.
    u = np.arange(-0.025, 0.025, 0.0005)
    w = np.where(np.abs(u) < 0.006, -0.012, 0.0) + rng.normal(0, 0.0003, len(u))
    seen = (np.abs(u) < 0.004) | (np.abs(u) > 0.008)
    assert fit_profile(u[seen], w[seen], **PARAMS) is None


def scan_lines(rows_x, rng, pitch=0.0005):
    """A plate (top z = 0) with a V-groove along x at y = 0.004, scanned in lines across it at `rows_x`."""
    y = np.arange(-0.03, 0.03, pitch)
    z = v_groove(0.004)(y)
    return np.vstack([np.column_stack([np.full(len(y), x), y, z + rng.normal(0, 0.0002, len(y))]) for x in rows_x])


def section_at_origin(points):
    params = section_params(SectionConfig(), voxel_m=0.001)
    travel, axis = np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 0.0, -1.0]])
    lateral = np.cross(travel, axis)
    return analyse_sections(points, cKDTree(points), np.zeros((1, 3)), travel, axis, lateral, params)[0]


def test_a_section_between_sparse_scan_lines_takes_a_thicker_slab(rng):
    points = scan_lines(np.arange(-0.042, 0.043, 0.004), rng)  # lines 2 mm either side of the section plane
    fit = section_at_origin(points)
    assert fit.joint == V_GROOVE
    assert abs(fit.point_m[1] - 0.004) < 0.0005 and abs(fit.point_m[2]) < 0.0005


def test_a_thicker_slab_never_reaches_back_from_past_the_part_end(rng):
    points = scan_lines(np.arange(-0.042, 0.0, 0.004), rng)  # the part ends 2 mm before the section plane
    assert section_at_origin(points).joint == ""


TEMPLATE = GrooveTemplate(left_m=0.0067, right_m=0.0067)  # where the sections before saw the surface end


def grooved_profile(rng, hole=None, pitch=0.0004):
    """u, w, along of a groove centred at u = 0.0005, 0.5 mm off the predicted seam (surface ends
    near -0.0065 and 0.0075), samples spread along the slab; `hole` (low, high) removes every
    point with u inside it."""
    u = np.arange(-0.025, 0.025, pitch)
    w = v_groove(0.0005, half_open=0.007)(u) + rng.normal(0, 0.0002, len(u))
    along = rng.uniform(-0.0015, 0.0015, len(u))
    if hole is not None:
        kept = (u < hole[0]) | (u > hole[1])
        u, w, along = u[kept], w[kept], along[kept]
    return u, w, along


def test_bridging_places_the_seam_from_the_edge_left_beside_a_dropout(rng):
    u, w, along = grooved_profile(rng, hole=(-0.005, 0.016))  # the right edge, the walls and 8 mm of surface lost
    assert fit_profile(u, w, **PARAMS) is None
    fit = bridge_groove(u, w, along, TEMPLATE, face_radius_m=0.012, groove_min_depth_m=0.0015)
    assert fit.joint == V_GROOVE
    assert abs(fit.u - 0.0005) < 0.0006 and abs(fit.w) < 0.0005 and fit.axis_w < -0.99


def test_bridging_uses_both_edges_when_only_the_groove_is_lost(rng):
    u, w, along = grooved_profile(rng, hole=(-0.006, 0.007))
    assert fit_profile(u, w, **PARAMS) is None
    fit = bridge_groove(u, w, along, TEMPLATE, face_radius_m=0.012, groove_min_depth_m=0.0015)
    assert abs(fit.u - 0.0005) < 0.0006


def test_bridging_refuses_what_is_not_a_groove_beside_a_hole(rng):
    bridge = dict(face_radius_m=0.012, groove_min_depth_m=0.0015)
    u, w, along = grooved_profile(rng, hole=(-0.005, 0.030))  # nothing beyond the hole: the plate's outer end
    assert bridge_groove(u, w, along, TEMPLATE, **bridge) is None
    flat_u = np.arange(-0.025, 0.025, 0.0004)
    flat = (flat_u < -0.005) | (flat_u > 0.001)  # a hole in a flat plate: surface runs where the opening should be
    assert bridge_groove(flat_u[flat], rng.normal(0, 0.0002, flat.sum()), rng.uniform(-0.0015, 0.0015, flat.sum()),
                         GrooveTemplate(0.007, 0.007), **bridge) is None  # fmt: skip
    u, w, along = grooved_profile(rng, hole=(-0.005, 0.016))
    assert bridge_groove(u, w, np.abs(along), TEMPLATE, **bridge) is None  # all surface behind the plane: past the end


def test_a_section_along_a_groove_wall_is_fitted_again_centred_on_the_groove():
    """A coarse seam line that runs along one groove wall (11.6 mm beside the seam, 4.6 mm down,
    its torch axis the wall's normal, 26 degrees off) on a rendered D415 scan: sections fitted in
    that frame alone miss by 0.6 mm on average, a quarter of them by over 1 mm."""
    rng = np.random.default_rng(0)
    scene = FAMILIES["v_butt"](rng)
    scan = make_scan(scene, rng)
    points = condition_points(scan.points_m, voxel_m=0.001)
    seam, visible = scene.seams[0], scan.visible[0]
    truth, truth_axes = seam.points_m[visible][::4], seam.torch_axes[visible][::4]
    travel = unit(np.gradient(truth, axis=0))
    truth_axes = unit(truth_axes - np.sum(truth_axes * travel, axis=1, keepdims=True) * travel)
    for side in (-1, 1):
        beside = side * np.cross(travel, truth_axes)
        wall_normal = unit(np.cos(np.radians(26)) * truth_axes + np.sin(np.radians(26)) * beside)
        fits = analyse_sections(
            points, cKDTree(points), truth + 0.0116 * beside + 0.0046 * truth_axes, travel, wall_normal,
            np.cross(travel, wall_normal), section_params(SectionConfig(), voxel_m=0.001),
        )
        errors = np.array([np.linalg.norm(f.point_m - p) for f, p in zip(fits, truth) if f.joint == V_GROOVE])
        assert len(errors) >= 0.95 * len(truth)
        assert errors.mean() < 0.0004 and np.mean(errors > 0.001) < 0.08


def plate_edge_beside_groove(rng, edge_y=-0.012, pitch=0.0005):
    """A plate (top z = 0) with a V-groove along x at y = 0 (opening 8 mm, 6 mm deep) whose edge
    runs along y = edge_y; beyond it the table, 10 mm down."""
    x, y = np.meshgrid(np.arange(-0.01, 0.01, 0.001), np.arange(-0.03, 0.03, pitch))
    x, y = x.ravel(), y.ravel()
    z = np.where(y < edge_y, -0.010, v_groove(0.0, half_open=0.004, depth=0.006)(y))
    return np.column_stack([x, y, z + rng.normal(0, 0.0002, len(x))])


def test_a_table_beside_the_groove_is_cut_off_when_the_groove_is_known(rng):
    """Where a plate edge crosses the section close beside the groove (the oblique end of a Y
    branch), the table beyond it spoils the full section's surface line; knowing the groove's
    opening from the sections before, the section is fitted again within opening + 6 mm."""
    points = plate_edge_beside_groove(rng)
    tree, params = cKDTree(points), section_params(SectionConfig(), voxel_m=0.001)
    travel, axis = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])
    assert fit_section(points, tree, np.zeros(3), travel, axis, params).joint == ""
    known = GrooveTemplate(left_m=None, right_m=None, half_opening_m=0.004)
    fit = fit_section(points, tree, np.zeros(3), travel, axis, params, known)
    assert fit.joint == V_GROOVE and not fit.bridged
    assert np.abs(fit.point_m).max() < 0.0003


def test_the_template_finds_both_surface_ends_of_a_noisy_groove(rng):
    """With 0.4 mm noise the surface band (3 sigma) takes in the top of each wall, a millimetre or
    so inside the edge; that is still a groove, and the surface ends it leaves are measured."""
    x, y = np.meshgrid(np.arange(-0.01, 0.01, 0.001), np.arange(-0.03, 0.03, 0.0006))
    z = v_groove(0.0, half_open=0.006, depth=0.006)(y.ravel())
    points = np.column_stack([x.ravel(), y.ravel(), z + rng.normal(0, 0.0004, x.size)])
    tree, params = cKDTree(points), section_params(SectionConfig(), voxel_m=0.001)
    travel = np.array([1.0, 0.0, 0.0])
    measured = []
    for centre_x in np.arange(-0.004, 0.0045, 0.002):
        fit = fit_section(points, tree, np.array([centre_x, 0.0, 0.0]), travel, np.array([0.0, 0.0, -1.0]), params)
        template = groove_template(points, tree, fit, travel, params)
        measured += [template.left_m, template.right_m]
    assert None not in measured
    assert np.all(np.abs(np.array(measured) - 0.006) < 0.0025)


def test_past_a_plate_end_the_table_is_seen_below_the_grooves_bottom(rng):
    """A 12 mm plate (end x = 0) with a 6 mm deep groove along x, on a table at z = -0.012."""
    x, y = np.meshgrid(np.arange(-0.06, 0.03, 0.0008), np.arange(-0.03, 0.03, 0.0008))
    x, y = x.ravel(), y.ravel()
    points = np.column_stack([x, y, np.where(x < 0, v_groove(0.0, half_open=0.006, depth=0.006)(y), -0.012)])
    points += rng.normal(0, 0.0001, points.shape)
    tree, params = cKDTree(points), section_params(SectionConfig(), voxel_m=0.001)
    travel, axis = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])
    near_end, far_from_end = (fit_section(points, tree, np.array([x, 0.0, 0.0]), travel, axis, params)
                              for x in (-0.004, -0.03))  # fmt: skip
    assert 0.005 < groove_bottom(points, tree, near_end, travel, params) <= 0.006  # depths even over 0-6 mm: ~5.4
    assert sees_past_end(points, tree, near_end, travel, 0.012, 0.006, params), "the table, 4 mm on"
    assert not sees_past_end(points, tree, far_from_end, travel, 0.012, 0.006, params), "the groove goes on"
    x, y = points[:, 0], points[:, 1]
    gap = (x > -0.03) & (x < 0) & (np.abs(y) < 0.0008)
    points[gap, 2] = -0.012  # a 1.6 mm root gap: the table is seen along the seam line
    assert not sees_past_end(points, cKDTree(points), far_from_end, travel, 0.012, 0.006, params)


def oblique_end_profile(rng, edge_u):
    """u, w, along of a groove centred at u = 0.0005 (10 mm deep, surface ends at -0.0065 and
    0.0075) whose right-hand plate has ended at `edge_u`: the table (w = -0.016) beyond it; three
    samples per u spread along the slab."""
    u = np.tile(np.arange(-0.025, 0.025, 0.0004), 3)
    w = np.where(u > edge_u, -0.016, v_groove(0.0005, half_open=0.007)(u)) + rng.normal(0, 0.0002, len(u))
    return u, w, rng.uniform(-0.0015, 0.0015, len(u))


def test_a_groove_past_one_side_of_an_oblique_plate_end_is_bridged_only_where_the_part_ends(rng):
    template = GrooveTemplate(left_m=0.0067, right_m=0.0067, half_opening_m=0.007, bottom_m=0.009)
    bridge = dict(face_radius_m=0.012, groove_min_depth_m=0.0015)
    u, w, along = oblique_end_profile(rng, edge_u=0.0025)
    assert bridge_groove(u, w, along, template, **bridge) is None, "no surface beyond: not a hole"
    fit = bridge_groove(u, w, along, template, **bridge, part_ends=True)
    assert fit.joint == V_GROOVE and abs(fit.u - 0.0005) < 0.0006
    u, w, along = oblique_end_profile(rng, edge_u=-0.002)  # the end has crossed the seam line
    assert bridge_groove(u, w, along, template, **bridge, part_ends=True) is None
