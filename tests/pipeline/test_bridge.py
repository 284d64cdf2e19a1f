import numpy as np

from tests.pipeline.test_joints import v_groove
from tests.pipeline.test_section import surface_of
from weldseam.config import JointsConfig
from weldseam.pipeline.bridge import GrooveTemplate, bridge_groove, fit_or_bridge, groove_bottom, groove_template, sees_past_end
from weldseam.pipeline.joints import JointKind, NoFit, fit_profile
from weldseam.pipeline.section import Profile

V_GROOVE = JointKind.V_GROOVE
PARAMS = JointsConfig()


def profile_of(u, w, along):
    """A section's points in the frame of a section at the origin across x, torch axis -z."""
    return Profile(u, w, along, np.zeros(3), np.array([0.0, 0.0, -1.0]), np.array([0.0, 1.0, 0.0]))


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
    assert isinstance(fit_profile(u, w, PARAMS), NoFit)
    fit = bridge_groove(profile_of(u, w, along), TEMPLATE, PARAMS)
    assert fit.kind == V_GROOVE
    assert abs(fit.u - 0.0005) < 0.0006 and abs(fit.w) < 0.0005 and fit.axis_w < -0.99


def test_bridging_uses_both_edges_when_only_the_groove_is_lost(rng):
    u, w, along = grooved_profile(rng, hole=(-0.006, 0.007))
    assert isinstance(fit_profile(u, w, PARAMS), NoFit)
    fit = bridge_groove(profile_of(u, w, along), TEMPLATE, PARAMS)
    assert abs(fit.u - 0.0005) < 0.0006


def test_bridging_refuses_what_is_not_a_groove_beside_a_hole(rng):
    u, w, along = grooved_profile(rng, hole=(-0.005, 0.030))  # nothing beyond the hole: the plate's outer end
    assert bridge_groove(profile_of(u, w, along), TEMPLATE, PARAMS) is None
    flat_u = np.arange(-0.025, 0.025, 0.0004)
    flat = (flat_u < -0.005) | (flat_u > 0.001)  # a hole in a flat plate: surface runs where the opening should be
    flat_profile = profile_of(flat_u[flat], rng.normal(0, 0.0002, flat.sum()), rng.uniform(-0.0015, 0.0015, flat.sum()))
    assert bridge_groove(flat_profile, GrooveTemplate(0.007, 0.007), PARAMS) is None
    u, w, along = grooved_profile(rng, hole=(-0.005, 0.016))
    assert bridge_groove(profile_of(u, w, np.abs(along)), TEMPLATE, PARAMS) is None  # all surface behind the plane: past the end


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
    surface = surface_of(points)
    travel, axis = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])
    assert fit_or_bridge(surface, np.zeros(3), travel, axis, None).kind is None
    known = GrooveTemplate(left_m=None, right_m=None, half_opening_m=0.004)
    fit = fit_or_bridge(surface, np.zeros(3), travel, axis, known)
    assert fit.kind == V_GROOVE and not fit.bridged
    assert np.abs(fit.point_m).max() < 0.0003


def test_the_template_finds_both_surface_ends_of_a_noisy_groove(rng):
    """With 0.4 mm noise the surface band (3 sigma) takes in the top of each wall, a millimetre or
    so inside the edge; that is still a groove, and the surface ends it leaves are measured."""
    x, y = np.meshgrid(np.arange(-0.01, 0.01, 0.001), np.arange(-0.03, 0.03, 0.0006))
    z = v_groove(0.0, half_open=0.006, depth=0.006)(y.ravel())
    points = np.column_stack([x.ravel(), y.ravel(), z + rng.normal(0, 0.0004, x.size)])
    surface = surface_of(points)
    travel = np.array([1.0, 0.0, 0.0])
    measured = []
    for centre_x in np.arange(-0.004, 0.0045, 0.002):
        fit = fit_or_bridge(surface, np.array([centre_x, 0.0, 0.0]), travel, np.array([0.0, 0.0, -1.0]), None)
        template = groove_template(surface, fit, travel)
        measured += [template.left_m, template.right_m]
    assert None not in measured
    assert np.all(np.abs(np.array(measured) - 0.006) < 0.0025)


def test_past_a_plate_end_the_table_is_seen_below_the_grooves_bottom(rng):
    """A 12 mm plate (end x = 0) with a 6 mm deep groove along x, on a table at z = -0.012."""
    x, y = np.meshgrid(np.arange(-0.06, 0.03, 0.0008), np.arange(-0.03, 0.03, 0.0008))
    x, y = x.ravel(), y.ravel()
    points = np.column_stack([x, y, np.where(x < 0, v_groove(0.0, half_open=0.006, depth=0.006)(y), -0.012)])
    points += rng.normal(0, 0.0001, points.shape)
    surface = surface_of(points)
    travel, axis = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])
    near_end, far_from_end = (fit_or_bridge(surface, np.array([x, 0.0, 0.0]), travel, axis, None)
                              for x in (-0.004, -0.03))  # fmt: skip
    assert 0.005 < groove_bottom(surface, near_end, travel) <= 0.006  # depths even over 0-6 mm: ~5.4
    assert sees_past_end(surface, near_end, travel, 0.012, 0.006), "the table, 4 mm on"
    assert not sees_past_end(surface, far_from_end, travel, 0.012, 0.006), "the groove goes on"
    x, y = points[:, 0], points[:, 1]
    gap = (x > -0.03) & (x < 0) & (np.abs(y) < 0.0008)
    points[gap, 2] = -0.012  # a 1.6 mm root gap: the table is seen along the seam line
    assert not sees_past_end(surface_of(points), far_from_end, travel, 0.012, 0.006)


def oblique_end_profile(rng, edge_u):
    """u, w, along of a groove centred at u = 0.0005 (10 mm deep, surface ends at -0.0065 and
    0.0075) whose right-hand plate has ended at `edge_u`: the table (w = -0.016) beyond it; three
    samples per u spread along the slab."""
    u = np.tile(np.arange(-0.025, 0.025, 0.0004), 3)
    w = np.where(u > edge_u, -0.016, v_groove(0.0005, half_open=0.007)(u)) + rng.normal(0, 0.0002, len(u))
    return u, w, rng.uniform(-0.0015, 0.0015, len(u))


def test_a_groove_past_one_side_of_an_oblique_plate_end_is_bridged_only_where_the_part_ends(rng):
    template = GrooveTemplate(left_m=0.0067, right_m=0.0067, half_opening_m=0.007, bottom_m=0.009)
    u, w, along = oblique_end_profile(rng, edge_u=0.0025)
    assert bridge_groove(profile_of(u, w, along), template, PARAMS) is None, "no surface beyond: not a hole"
    fit = bridge_groove(profile_of(u, w, along), template, PARAMS, part_ends=True)
    assert fit.kind == V_GROOVE and abs(fit.u - 0.0005) < 0.0006
    u, w, along = oblique_end_profile(rng, edge_u=-0.002)  # the end has crossed the seam line
    assert bridge_groove(profile_of(u, w, along), template, PARAMS, part_ends=True) is None
