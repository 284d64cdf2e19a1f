from dataclasses import replace

import numpy as np
import pytest

from tests.pipeline.test_section import surface_of
from weldseam.config import ExtendConfig
from weldseam.geometry import polyline_length
from weldseam.pipeline.ends import end_curve, seam_line
from weldseam.pipeline import ends, extend
from weldseam.pipeline.extend import _larger_pieces, extend_seam, extend_seams
from weldseam.pipeline.holes import HOLE_EDGE_M, _arrival, _bridge, hole_aim, hole_aims
from weldseam.pipeline.parallel import worker_process
from weldseam.pipeline.section import PointFlag, SectionFit
from weldseam.pipeline.seek import Extension
from weldseam.pipeline.joints import JointGeometry, JointKind
from weldseam.pipeline.trace import TracedSeam

RING_RADIUS_M = 0.05
STEP_M = 0.002


def ring_groove_plate(rng, pitch=0.0008, half_open=0.006, depth=0.006):
    """A plate (z = 0 top) with a V-groove around a circle of RING_RADIUS_M, sampled on a grid, 0.1 mm noise."""
    axis = np.arange(-0.085, 0.085, pitch)
    x, y = np.meshgrid(axis, axis)
    across = np.abs(np.hypot(x, y) - RING_RADIUS_M)
    z = -np.clip((half_open - across) * depth / half_open, 0, None) + rng.normal(0, 0.0001, x.shape)
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()])


def ring_arc(start_rad, end_rad):
    angles = np.arange(start_rad, end_rad, STEP_M / RING_RADIUS_M)
    positions = RING_RADIUS_M * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))])
    return TracedSeam(positions, np.tile([0.0, 0.0, -1.0], (len(angles), 1)), False, JointKind.V_GROOVE, 1.0)


def test_an_extension_round_a_loop_stops_where_it_meets_the_seam(rng):
    points = ring_groove_plate(rng)
    seam = ring_arc(0.0, 1.5 * np.pi)  # three quarters of the ring traced; the rest is for extension
    positions = extended(seam, points)
    radii = np.hypot(positions[:, 0], positions[:, 1])
    assert np.abs(radii - RING_RADIUS_M).max() < 0.0005, "the extension follows the groove"
    circumference = 2 * np.pi * RING_RADIUS_M
    assert polyline_length(positions) > 0.9 * circumference, "the missing quarter is filled in"
    assert polyline_length(positions) < circumference, "and it does not go round a second time"
    assert np.linalg.norm(positions[0] - positions[-1]) <= 3 * STEP_M, "the ends meet, so the seam can close"


def v_depth(across, half_open=0.006, depth=0.005):
    return np.clip((half_open - np.abs(across)) * depth / half_open, 0, None)


def grid(first, second, pitch=0.0008):
    a, b = np.meshgrid(np.arange(*first, pitch), np.arange(*second, pitch))
    return a.ravel(), b.ravel()


def straight_trace(start_x, end_x, axis):
    x = np.arange(start_x, end_x, STEP_M)
    positions = np.column_stack([x, np.zeros(len(x)), np.zeros(len(x))])
    return TracedSeam(positions, np.tile(axis, (len(x), 1)), False, JointKind.V_GROOVE, 1.0)


def extended(seam, points, max_hole_m=0.05):
    params = replace(ExtendConfig(), step_m=STEP_M, max_hole_m=max_hole_m)
    return extend_seam(seam, surface_of(points), params).positions_m


def test_an_extension_follows_a_groove_over_a_block_edge_and_keeps_the_corner(rng):
    """A groove along x on a block's top (z = 0, x <= 0) that runs on down its side face (x = 0)."""
    x, y = grid((-0.08, 0.0), (-0.03, 0.03))
    top = np.column_stack([x, y, -v_depth(y)])
    z, y = grid((-0.07, 0.0), (-0.03, 0.03))
    side = np.column_stack([-v_depth(y), y, z])
    points = np.vstack([top, side]) + rng.normal(0, 0.0001, (len(top) + len(side), 3))
    positions = extended(straight_trace(-0.06, -0.03, [0.0, 0.0, -1.0]), points)
    down_the_side = positions[positions[:, 2] < -0.01]
    assert len(down_the_side) > 10 and np.abs(down_the_side[:, :2]).max() < 0.0005
    assert down_the_side[:, 2].min() < -0.05, "followed to near the side's bottom"
    assert np.linalg.norm(positions, axis=1).min() < 0.001, "the corner itself is on the path"


def plate_ending_on_a_table(rng):
    """A 10 mm plate (top z = 0, end face x = 0) on a table (z = -0.01): its groove along x ends at the plate end."""
    x, y = grid((-0.08, 0.0), (-0.03, 0.03))
    top = np.column_stack([x, y, -v_depth(y, depth=0.01)])
    z, y = grid((-0.01, 0.0), (-0.03, 0.03))
    end_face = np.column_stack([-v_depth(y, depth=0.01) * (z > -0.01), y, z])
    x, y = grid((0.0, 0.06), (-0.03, 0.03))
    table = np.column_stack([x, y, np.full(len(x), -0.01)])
    return np.vstack([top, end_face, table]) + rng.normal(0, 0.0001, (len(top) + len(end_face) + len(table), 3))


def test_an_extension_does_not_turn_down_a_plate_end(rng):
    positions = extended(straight_trace(-0.06, -0.03, [0.0, 0.0, -1.0]), plate_ending_on_a_table(rng))
    assert positions[:, 2].min() > -0.002 and positions[:, 0].max() < 0.002, "the seam ends at the plate end"


def test_an_extension_bridges_a_dropout_over_one_edge_and_stops_at_the_plate_end(rng):
    points = plate_ending_on_a_table(rng)
    x, y, z = points.T
    dropout = (x > -0.045) & (x < -0.012) & (y > -0.004) & (y < 0.016) & (z > -0.009)  # 33 mm: the right edge lost
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), points[~dropout])
    across = positions[(positions[:, 0] > -0.043) & (positions[:, 0] < -0.014)]
    assert np.diff(np.sort(across[:, 0])).max() < 2.5 * STEP_M, "no stretch of the dropout left without poses"
    assert np.abs(across[:, 1:]).max() < 0.0005, "bridged on the groove"
    # Sections that straddle the dropout's far boundary fit less well; they stay within 1.5 mm.
    assert np.abs(positions[:, 1:]).max() < 0.0015
    assert -0.007 < positions[:, 0].max() < 0.002, "goes on past the dropout to the plate end, not beyond it"


def test_an_extension_crosses_a_hole_in_the_scan_and_goes_on_to_the_plate_end(rng):
    points = plate_ending_on_a_table(rng)
    hole = (points[:, 0] > -0.045) & (points[:, 0] < -0.015)  # 30 mm with no data across the whole window
    seam = straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0])
    positions = extended(seam, points[~hole])
    across = positions[(positions[:, 0] > -0.046) & (positions[:, 0] < -0.014)]
    assert np.diff(np.sort(across[:, 0])).max() < 1.5 * STEP_M, "the hole is filled with poses"
    assert np.abs(across[:, 1:]).max() < 0.0005, "on the seam line"
    assert np.abs(positions[:, 1:]).max() < 0.0015  # as in the dropout test: the plate end's sections straddle it
    assert -0.008 < positions[:, 0].max() < 0.002, "on to the plate end, not beyond it"
    assert extended(seam, points[~hole], max_hole_m=0.0)[:, 0].max() < -0.04, "max_hole_m = 0: stops at the hole"


def test_an_extension_does_not_cross_a_stretch_hidden_under_a_bar(rng):
    """The hole of the test above, but the groove is missing because a bar 30 mm over the plate
    hides it from the camera: a torch sent across would run into the bar, so the seam stops at
    the bar; with the bar's points taken away (a dropout, nothing in front) it is crossed."""
    from scipy.spatial import cKDTree

    from weldseam.config import PlanConfig
    from weldseam.pipeline.occlusion import ViewBuffer
    from weldseam.pipeline.section import FineSurface, section_params

    camera = np.array([-0.03, 0.0, 0.4])
    points = plate_ending_on_a_table(rng)
    x = points[:, 0]
    under = points[~((x > -0.045) & (x < -0.015))]
    bx, by = grid((-0.043, -0.017), (-0.03, 0.03))
    bar = np.column_stack([bx, by, np.full(len(bx), 0.03)])
    seam = straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0])
    params = replace(ExtendConfig(), step_m=STEP_M, max_hole_m=0.05)
    for seen, crossed in ((under, True), (np.vstack([under, bar]), False)):
        surface = FineSurface(seen, cKDTree(seen), section_params(PlanConfig()), ViewBuffer.build(seen, camera, 0.001))
        reach = extend_seam(seam, surface, params).positions_m[:, 0].max()
        assert (reach > -0.01) if crossed else (reach < -0.04)


def plate_with_a_hole_up_to_its_end(rng):
    """A 12 mm plate (top z = 0, end x = 0) with a 6 mm deep groove along x on a table (z = -0.012),
    seen from above; a dropout covers the groove's last 45 mm but for a strip at 2.6-4 mm from the
    end, where one section fits. Returns the points and whether each is on the table."""
    x, y = grid((-0.08, 0.04), (-0.03, 0.03))
    points = np.column_stack([x, y, np.where(x < 0, -v_depth(y, depth=0.006), -0.012)])
    points += rng.normal(0, 0.0001, points.shape)
    x = points[:, 0]
    kept = ~(((x > -0.045) & (x < -0.004)) | ((x > -0.0026) & (x < 0)))
    return points[kept], x[kept] >= 0


def test_an_extension_crosses_a_hole_to_one_section_before_the_plate_end(rng):
    """One fit beyond the hole, and the table seen right after it: the part ends there."""
    points, _ = plate_with_a_hole_up_to_its_end(rng)
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), points)
    across = positions[(positions[:, 0] > -0.046) & (positions[:, 0] < -0.004)]
    assert np.diff(np.sort(across[:, 0])).max() < 1.5 * STEP_M, "the hole is filled with poses"
    assert np.abs(positions[:, 1:]).max() < 0.0015
    assert -0.0035 < positions[:, 0].max() < 0.002, "on to the plate end, not beyond it"


def test_one_section_beyond_a_hole_with_nothing_seen_past_it_does_not_carry_the_seam_across(rng):
    """Without the table behind the plate's end, the one fit could be a stray inside a longer hole."""
    points, on_table = plate_with_a_hole_up_to_its_end(rng)
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), points[~on_table])
    assert positions[:, 0].max() < -0.04


def plate_with_an_oblique_end(rng):
    """A 12 mm plate (top z = 0) with a 6 mm deep groove along x, on a table (z = -0.012), seen
    from above; its end x = y crosses the groove at 45 degrees (the seam ends at x = 0). Returns
    the points and whether each is on the plate."""
    x, y = grid((-0.08, 0.04), (-0.03, 0.03))
    on_plate = x < y
    points = np.column_stack([x, y, np.where(on_plate, -v_depth(y, depth=0.006), -0.012)])
    return points + rng.normal(0, 0.0001, points.shape), on_plate


def test_an_extension_follows_a_groove_to_where_an_oblique_plate_end_crosses_it(rng):
    """Over the last 6 mm the plate on one side has ended and the table shows there."""
    points, _ = plate_with_an_oblique_end(rng)
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), points)
    assert -0.002 < positions[:, 0].max() < 0.001, "to the seam's end, not beyond it"
    assert np.abs(positions[:, 1:]).max() < 0.001


def test_an_extension_does_not_pass_an_oblique_plate_end_with_nothing_seen_past_it(rng):
    """Without the table, one side's plate ending is no sign that the seam ends just ahead."""
    points, on_plate = plate_with_an_oblique_end(rng)
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), points[on_plate])
    assert positions[:, 0].max() < 0.0


def plates_in_line_with_a_gap(rng, gap_m):
    """Two 12 mm plates (top z = 0) in line, each with a 6 mm deep groove along x, on a table
    (z = -0.012) that shows through a gap of `gap_m` between them starting at x = -0.03."""
    x, y = grid((-0.08, 0.06), (-0.03, 0.03))
    in_gap = (x >= -0.03) & (x < -0.03 + gap_m)
    points = np.column_stack([x, y, np.where(in_gap, -0.012, -v_depth(y, depth=0.006))])
    return points + rng.normal(0, 0.0001, points.shape)


@pytest.mark.parametrize("gap_m", [0.012, 0.02, 0.03])
def test_an_extension_stops_at_a_plate_end_where_the_table_shows_before_the_next_plate(rng, gap_m):
    """The camera sees the table through the gap: the seam ends there, and the groove in line on
    the next plate is another seam, not the same one across a hole."""
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), plates_in_line_with_a_gap(rng, gap_m))
    assert -0.033 < positions[:, 0].max() < -0.028, "to the plate end, not across the gap"
    assert np.abs(positions[:, 1:]).max() < 0.0015


def test_an_extension_never_crosses_where_the_groove_stops_and_flat_plate_goes_on(rng):
    """A groove along x interrupted for 20 mm (-0.04 < x < -0.02) by flat plate, then going on:
    two seams in line, and the weld must not be carried across the flat stretch."""
    x, y = grid((-0.08, 0.02), (-0.03, 0.03))
    groove = (x < -0.04) | (x > -0.02)
    points = np.column_stack([x, y, -v_depth(y) * groove]) + rng.normal(0, 0.0001, (len(x), 3))
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), points)
    assert positions[:, 0].max() < -0.036


def test_an_extension_crosses_a_hole_on_a_curved_seam_along_the_curve(rng):
    points = ring_groove_plate(rng)
    angle = np.arctan2(points[:, 1], points[:, 0]) % (2 * np.pi)
    hole = (angle > 1.65 * np.pi) & (angle < 1.65 * np.pi + 0.035 / RING_RADIUS_M)  # 35 mm of the ring
    positions = extended(ring_arc(0.0, 1.5 * np.pi), points[~hole])
    radii = np.hypot(positions[:, 0], positions[:, 1])
    assert np.abs(radii - RING_RADIUS_M).max() < 0.0005, "the hole is bridged along the ring, not across it"
    assert polyline_length(positions) > 0.95 * 2 * np.pi * RING_RADIUS_M
    assert np.linalg.norm(positions[0] - positions[-1]) <= 3 * STEP_M


def test_an_extension_whose_end_leans_into_the_work_still_finds_the_seam_past_a_gap(rng):
    """The last traced points sink 1 mm into the work over 10 mm (poorly fitted end sections),
    so the end tangent leans 6 degrees into the plate, and the next 8 mm hold no data: the fits
    beyond lie 1-2 mm above the predictions, which is still the seam."""
    points = plate_ending_on_a_table(rng)
    gap = (points[:, 0] > -0.045) & (points[:, 0] < -0.037)
    seam = straight_trace(-0.075, -0.047, [0.0, 0.0, -1.0])
    leaning = seam.positions_m.copy()
    leaning[:, 2] = -np.clip(leaning[:, 0] + 0.057, 0.0, None) * np.tan(np.radians(6))
    positions = extended(TracedSeam(leaning, seam.torch_axes, False, JointKind.V_GROOVE, 1.0), points[~gap])
    beyond = positions[positions[:, 0] > -0.035]
    assert len(beyond) > 10 and np.abs(beyond[:, 1:]).max() < 0.0015
    assert positions[:, 0].max() > -0.008, "on to the plate end"


def leaning_end_trace():
    """A straight trace along x to x = -0.049 whose last three points lean 0.5, 1.5 and 3 mm
    sideways, as fits do where a hole's edge cuts their sections short (one groove wall seen)."""
    seam = straight_trace(-0.075, -0.047, [0.0, 0.0, -1.0])
    leaning = seam.positions_m.copy()
    leaning[-3:, 1] = [0.0005, 0.0015, 0.003]
    return TracedSeam(leaning, seam.torch_axes, False, JointKind.V_GROOVE, 1.0)


def test_a_hole_is_aimed_across_from_the_seam_before_the_fits_that_lean_at_its_edge():
    seam = leaning_end_trace().positions_m
    end_tangent = end_curve(seam)[0]
    assert np.degrees(np.arccos(end_tangent[0])) > 5, "the end's own tangent leans with the last fits"
    origin, direction, bend = hole_aim(seam)
    assert origin[0] < seam[-1][0] - HOLE_EDGE_M + 1e-9 and abs(origin[1]) < 1e-4, "a fit before the edge"
    assert np.degrees(np.arccos(direction[0])) < 0.5 and np.linalg.norm(bend) < 1.0, "along the seam there"
    assert hole_aim(seam[-5:]) is None, "fewer than three fits before the edge: no second aim"


def test_an_extension_crosses_a_short_hole_after_fits_that_lean_at_its_edge(rng):
    """14 mm without data after the leaning end. Sought along the end's own tangent, the groove
    beyond lies 9-11 mm sideways of the predictions, too far to be taken for it; sought from
    before the hole's edge it is on the line, and carried on to the plate end."""
    points = plate_ending_on_a_table(rng)
    hole = (points[:, 0] > -0.0465) & (points[:, 0] < -0.0325)
    positions = extended(leaning_end_trace(), points[~hole])
    beyond = positions[(positions[:, 0] > -0.03) & (positions[:, 0] < -0.01)]
    assert len(beyond) >= 8 and np.abs(beyond[:, 1:]).max() < 0.001, "found on the groove beyond the hole"
    assert positions[:, 0].max() > -0.008, "on to the plate end"


def test_a_hole_is_sought_straight_on_where_the_ends_curve_and_the_curve_before_its_edge_disagree():
    """The end's curve bends with the fits that lean at the hole's edge, the curve before the edge
    does not: 50 mm ahead they lie too far apart for a fit to match both, the bend is no seam's,
    and their tangents are the aims, straight on. Along a ring both curves agree, and are the aims."""
    seam = leaning_end_trace().positions_m
    leaning = end_curve(seam)
    aims = hole_aims(seam[-1], *leaning, seam, 0.05)
    assert len(aims) == 2 and not aims[0][2].any() and not aims[1][2].any()
    assert np.allclose(aims[0][1], leaning[0]) and np.allclose(aims[1][1], hole_aim(seam)[1])
    ring = ring_arc(0.0, np.pi).positions_m
    curves = hole_aims(ring[-1], *end_curve(ring), ring, 0.05)
    assert len(curves) == 2 and all(np.linalg.norm(bend) > 0.9 / RING_RADIUS_M for _, _, bend in curves)


def test_a_groove_is_not_carried_across_a_hole_to_a_square_butts_gap_in_line(rng):
    """A V-groove (x < -0.045), 30 mm without data, then a square butt's 1.5 mm gap in line, its
    far wall seen obliquely: the V-groove's model fits that gap too (one wall, no flank), but fitted
    for every joint the section there is the butt, and the groove does not go on to it."""
    x, y = grid((-0.08, 0.0), (-0.03, 0.03))
    groove, butt = x < -0.045, x > -0.015
    kept = groove | (butt & (np.abs(y) > 0.00075))
    points = np.column_stack([x, y, np.where(groove, -v_depth(y), 0.0)])[kept]
    wall_x, wall_z = grid((-0.015, 0.0), (-0.005, 0.0))
    wall = np.column_stack([wall_x, 0.00075 + 0.4 * wall_z, wall_z])
    points = np.vstack([points, wall]) + rng.normal(0, 0.0001, (len(points) + len(wall), 3))
    positions = extended(straight_trace(-0.075, -0.055, [0.0, 0.0, -1.0]), points)
    assert positions[:, 0].max() < -0.04


def test_a_hole_on_a_straight_aim_is_bridged_along_it_not_the_lean_of_the_first_two_fits_beyond_it():
    """The first fits beyond a 36 mm hole lean 14 degrees (0.5 mm over a step, as fits do at a hole's
    edge); the curve across, its tangents as long as the hole, would bulge 1.3 mm off the seam
    arriving along them. Found along a straight aim, it arrives along that line and stays on it."""
    far = np.column_stack([np.full(4, 0.5), np.arange(4.0), np.zeros(4)])  # no scan point near the hole
    extension = Extension(surface_of(far), JointKind.V_GROOVE, replace(ExtendConfig(), step_m=STEP_M))
    down = np.array([0.0, 0.0, -1.0])
    run = [SectionFit(JointKind.V_GROOVE, np.array([0.036, 0.0, 0.0]), down),
           SectionFit(JointKind.V_GROOVE, np.array([0.038, 0.0005, 0.0]), down)]
    along = np.array([1.0, 0.0, 0.0])
    fits = _bridge(extension, np.zeros(3), down, along, run, _arrival(run, along, np.zeros(3)))
    bridged = np.array([fit.point_m for fit in fits if fit.bridged])
    assert len(bridged) >= 15 and np.abs(bridged[:, 1]).max() < 0.0002


@pytest.mark.parametrize("with_worker", [False, True])
def test_extending_the_ends_apart_gives_the_seams_extended_one_end_after_the_other(rng, with_worker):
    """The ends of a loop's arc meet (one stops where the other's extension is, across a hole in
    the gap), a second seam on the rest of the ring is shorter than the ends' look-back (extended
    one end after the other, stopping short of the larger arc) and a third is closed (left alone,
    away from the ring)."""
    points = ring_groove_plate(rng)
    gap = np.abs(np.arctan2(points[:, 1], points[:, 0]) + 0.4) < 0.15
    points = points[~(gap & (np.abs(np.hypot(points[:, 0], points[:, 1]) - RING_RADIUS_M) < 0.03))]
    surface = surface_of(points)
    closed = ring_arc(0.0, 2 * np.pi)
    seams = [ring_arc(0.0, 1.5 * np.pi), ring_arc(1.55 * np.pi, 1.55 * np.pi + 0.3), TracedSeam(
        closed.positions_m + [0.0, 0.0, 0.5], closed.torch_axes, True, JointKind.V_GROOVE, 1.0)]
    params = replace(ExtendConfig(), step_m=STEP_M)
    one_after_the_other = [extend_seam(seam, surface, params, _larger_pieces(seams, k)) for k, seam in enumerate(seams)]
    if with_worker:
        with worker_process(surface):
            apart = extend_seams(seams, surface, params)
    else:
        apart = extend_seams(seams, surface, params)
    assert one_after_the_other[0].holes, "the loop's ends meet across the hole"
    assert len(one_after_the_other[1].positions_m) > len(seams[1].positions_m)
    for serial, parallel in zip(one_after_the_other, apart):
        assert serial.positions_m.tobytes() == parallel.positions_m.tobytes()
        assert serial.torch_axes.tobytes() == parallel.torch_axes.tobytes()
        assert serial.holes == parallel.holes and serial.closed == parallel.closed


def test_an_extension_stops_short_of_the_points_it_is_given_to_stop_at(rng):
    """A piece of 3 sections at x = 60-64 mm on a straight groove, told to stop at a piece traced
    at x = -50-8 mm: its extension ends two steps short of it, not over it."""
    x, y = grid((-0.09, 0.09), (-0.02, 0.02))
    points = np.column_stack([x, y, -v_depth(y) + rng.normal(0, 0.0001, len(x))])
    axis = [0.0, 0.0, -1.0]
    small, large = straight_trace(0.060, 0.0645, axis), straight_trace(-0.050, 0.008, axis)
    params = replace(ExtendConfig(), step_m=STEP_M)
    stopped = extend_seam(small, surface_of(points), params, large.positions_m).positions_m[:, 0]
    assert 0.008 + STEP_M < stopped.min() < 0.008 + 3 * STEP_M
    assert extend_seam(small, surface_of(points), params).positions_m[:, 0].min() < -0.08, "else it runs on"


def test_a_hole_crossed_up_to_the_points_it_is_given_to_stop_at_keeps_its_fits_short_of_them(rng):
    """The hole of the test above (30 mm, x = -45..-15 mm), a piece of 3 sections before it, told
    to stop at a piece traced from x = -12 mm on: it crosses the hole (interpolated poses on the
    seam line) and ends two steps short of that piece, not at the plate's end."""
    points = plate_ending_on_a_table(rng)
    hole = (points[:, 0] > -0.045) & (points[:, 0] < -0.015)
    axis = [0.0, 0.0, -1.0]
    small, ahead = straight_trace(-0.060, -0.0555, axis), straight_trace(-0.012, -0.005, axis)
    params = replace(ExtendConfig(), step_m=STEP_M, max_hole_m=0.05)
    positions = extend_seam(small, surface_of(points[~hole]), params, ahead.positions_m).positions_m
    across = positions[(positions[:, 0] > -0.044) & (positions[:, 0] < -0.017)]
    assert len(across) and np.diff(np.sort(across[:, 0])).max() < 1.5 * STEP_M, "the hole is crossed"
    assert -0.012 - 3 * STEP_M < positions[:, 0].max() < -0.012 - STEP_M, "and stops short of the piece ahead"


def test_only_a_piece_of_a_few_sections_stops_and_only_at_a_larger_piece_of_another_joint():
    """A piece's few sections name its joint; carried over a larger piece of another joint, the
    longest kept, it would rename that one. A piece of the same joint, or a piece traced over six
    sections or more, extends as it would alone."""
    axis = [0.0, 0.0, -1.0]
    small = replace(straight_trace(0.060, 0.0645, axis), joint=JointKind.FILLET)
    large = straight_trace(-0.050, 0.008, axis)
    same = replace(straight_trace(0.07, 0.072, axis), joint=JointKind.FILLET)
    longer = replace(straight_trace(0.1, 0.12, axis), joint=JointKind.FILLET)
    seams = [small, large, same, longer]
    assert _larger_pieces(seams, 0).tobytes() == large.positions_m.tobytes()
    assert len(_larger_pieces(seams, 2)) == len(large.positions_m)
    assert len(_larger_pieces(seams, 3)) == 0 and len(_larger_pieces(seams, 1)) == 0


def one_face_ahead(on_ring: bool, flags: int = int(PointFlag.ONE_FACE)):
    """A stand-in for seek.next_fit giving a corner with one face unseen (`flags`) a step ahead: on
    the ring of RING_RADIUS_M (a fillet's foot), or on the tangent line from the ring's point at
    angle 0 (a shadow's edge past a standing pipe's silhouette, running off along the line of sight)."""

    def fit(extension, last_point, last_axis, heading, template=None, line=None, end_spread=None):
        if on_ring:
            angle = np.arctan2(last_point[1], last_point[0]) + STEP_M / RING_RADIUS_M
            point = RING_RADIUS_M * np.array([np.cos(angle), np.sin(angle), 0.0])
        else:
            point = last_point + STEP_M * np.array([0.0, 1.0, 0.0])
        return SectionFit(JointKind.FILLET, point, np.array([0.0, 0.0, -1.0]), flags=flags)

    return fit


OUTLINE = int(PointFlag.ONE_FACE | PointFlag.OUTLINE)


@pytest.mark.parametrize("on_ring", [True, False])
@pytest.mark.parametrize("flags", [int(PointFlag.ONE_FACE), OUTLINE])
def test_corners_with_one_face_unseen_are_followed_only_along_the_curve_of_the_full_fits(monkeypatch, on_ring, flags):
    """A ring fillet (radius 50 mm) traced up to angle 0 with both faces seen, then extended by
    corners with one face seen: along the ring they carry it on (for 30 mm at least: the curve
    predicted from the full fits is a parabola, ~8 % of the arc off the ring by 35 mm); along the ring's tangent (the
    visible end of the plate in the pipe's shadow) they are taken only while they stay within
    8 % of their arc of the ring (d^2 / 2R: the first 8 mm), and the seam never leaves it by a
    millimetre. So are those placed from an occluder's outline (the pipe near its silhouette)."""
    monkeypatch.setattr(extend, "next_fit", one_face_ahead(on_ring, flags))
    monkeypatch.setattr(extend, "STRATEGIES", (extend._next_step,))
    seam = ring_arc(-1.0, STEP_M / RING_RADIUS_M / 2)
    extension = Extension(None, JointKind.FILLET, replace(ExtendConfig(), max_extension_m=0.05))
    steps, _ = extend.extend_end(extension, seam.positions_m, seam.torch_axes)
    points = np.array([fit.point_m for step in steps for fit in step.fits])
    off_ring = np.abs(np.linalg.norm(points[:, :2], axis=1) - RING_RADIUS_M)
    if on_ring:
        assert len(points) >= 15 and off_ring.max() < 1e-9
    else:
        assert 2 <= len(points) <= 5 and off_ring.max() < 0.001


def test_a_seam_seen_with_one_face_all_along_is_extended_by_its_one_face_corners(monkeypatch):
    """A T-joint seen from above has one face unseen along its whole length: with no fit of both
    faces to hold them to, its one-face corners carry it on wherever they lead."""
    monkeypatch.setattr(extend, "next_fit", one_face_ahead(on_ring=False))
    monkeypatch.setattr(extend, "STRATEGIES", (extend._next_step,))
    seam = ring_arc(-1.0, STEP_M / RING_RADIUS_M / 2)
    flags = np.full(len(seam.positions_m), int(PointFlag.ONE_FACE), np.uint8)
    extension = Extension(None, JointKind.FILLET, replace(ExtendConfig(), max_extension_m=0.05))
    steps, _ = extend.extend_end(extension, seam.positions_m, seam.torch_axes, flags)
    assert len(steps) == 25


def drifting_end_trace(drift_m):
    """A trace along the groove (y = 0) whose last four points drift sideways to `drift_m`, as the
    fits beside a plate's end or a table do."""
    seam = straight_trace(-0.075, -0.043, [0.0, 0.0, -1.0])
    positions = seam.positions_m.copy()
    positions[-4:, 1] = drift_m * np.arange(1, 5) / 4
    return replace(seam, positions_m=positions)


@pytest.mark.parametrize("drift_m", [0.0035, 0.0045])
def test_an_extension_past_an_end_that_drifts_sideways_goes_on_along_the_seams_line(rng, drift_m):
    """The curve through the drifting end points aims 3-5 mm off the groove within a few steps;
    the seam's line over its last stretch does not."""
    positions = extended(drifting_end_trace(drift_m), plate_ending_on_a_table(rng))
    beyond = positions[positions[:, 0] > -0.042]
    assert len(beyond) and beyond[:, 0].max() > -0.006, "the groove is followed on to near the plate end"
    # As in the dropout test, the last sections straddle the plate end; before them, on the groove.
    assert np.abs(beyond[beyond[:, 0] < -0.012, 1]).max() < 0.0005, "on the groove, not on the drift's continuation"


def rippled_valley_plate(rng, included_deg=140.0, pitch=0.0008):
    """Two faces meeting in a valley of `included_deg` along x (0-150 mm) at y = 0, under a
    sensor's 1.5 mm of ripple (three waves of 8-20 mm) and 0.2 mm noise."""
    x, y = grid((0.0, 0.15), (-0.035, 0.035), pitch)
    z = np.tan(np.radians((180.0 - included_deg) / 2)) * np.abs(y)
    for wave_m, amplitude_m, angle in ((0.02, 0.0007, 0.3), (0.013, 0.0005, 1.9), (0.008, 0.0003, 2.6)):
        z = z + amplitude_m * np.sin((x * np.cos(angle) + y * np.sin(angle)) * 2 * np.pi / wave_m)
    return np.column_stack([x, y, z + rng.normal(0, 0.0002, len(x))])


# A shallow valley's corner as sections in ripple find it: 4 mm across from one to the next.
SCATTERED_ACROSS_M = np.array([0.0, 0.3, 0.8, 4.0, 3.5, 3.2, -0.7]) / 1000


def test_an_extension_follows_a_shallow_rippled_valley_whose_corner_scatters_across(rng):
    along = np.linspace(0.012, 0.027, len(SCATTERED_ACROSS_M))
    seam = TracedSeam(np.column_stack([along, SCATTERED_ACROSS_M, np.zeros(len(along))]),
                      np.tile([0.0, 0.0, -1.0], (len(along), 1)), False, JointKind.FILLET, 1.0,
                      across_spread=JointGeometry(included_deg=140.0).across_spread)
    positions = extended(seam, rippled_valley_plate(rng))
    assert positions[:, 0].max() > 0.14, "to the valley's end, 150 mm"
    assert np.abs(positions[:, 1]).max() < 0.006, "on the valley: a 140-degree corner's scatter across"


def test_the_line_through_scattered_end_points_keeps_the_seams_direction_where_their_curve_does_not():
    along = np.linspace(0.012, 0.027, len(SCATTERED_ACROSS_M))
    points = np.column_stack([along, SCATTERED_ACROSS_M, np.zeros(len(along))])
    assert seam_line(points).direction @ [1.0, 0.0, 0.0] > np.cos(np.radians(8.0))
    assert end_curve(points)[0] @ [1.0, 0.0, 0.0] < np.cos(np.radians(30.0)), "the quadratic follows the scatter"


def test_a_seam_seen_with_one_face_all_along_is_not_extended_by_corners_placed_from_an_outline(monkeypatch):
    """With no fit of both faces, a corner whose unseen face is only an occluder's outline (the
    edge of a standing pipe's shadow) leads nowhere: it carries no seam on."""
    monkeypatch.setattr(extend, "next_fit", one_face_ahead(on_ring=False, flags=OUTLINE))
    monkeypatch.setattr(extend, "STRATEGIES", (extend._next_step,))
    seam = ring_arc(-1.0, STEP_M / RING_RADIUS_M / 2)
    flags = np.full(len(seam.positions_m), int(PointFlag.ONE_FACE), np.uint8)
    extension = Extension(None, JointKind.FILLET, replace(ExtendConfig(), max_extension_m=0.05))
    steps, _ = extend.extend_end(extension, seam.positions_m, seam.torch_axes, flags)
    assert steps == []


@pytest.mark.parametrize("radius_m", [0.035, 0.06])
def test_an_end_on_a_tight_curve_is_also_sought_along_its_curve_and_a_straight_one_is_not(radius_m):
    """Past failed sections a seam is sought up to max_skip_m ahead. Straight on from an end on a
    ring of 35-60 mm, 12 mm ahead is 1.2-2.1 mm off the ring and a section there cuts it 11-20
    degrees askew; along the end's curve it is on the ring. A straight end has no curve to add."""
    params = ExtendConfig()
    angles = np.arange(0.0, 0.04 / radius_m, params.step_m / radius_m)
    ring = radius_m * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))])
    along = np.arange(0.0, 0.04, params.step_m)
    straight = np.column_stack([along, np.zeros(len(along)), np.zeros(len(along))])
    for points, curved in ((ring, True), (straight, False)):
        down = [np.array([0.0, 0.0, -1.0])] * len(points)
        end = extend.SeamEnd(list(points), down, [False] * len(points), *end_curve(points), params.step_m,
                             params.max_skip_m)
        aims = end.aims(seam_line(points))
        assert len(aims) == (2 if curved else 1)
        ahead = [ends.ahead(points[-1], direction, bend, params.max_skip_m)[0] for direction, bend in aims]
        off_ring = [abs(np.hypot(*point[:2]) - radius_m) for point in ahead]
        if curved:
            assert off_ring[0] > 0.0011 and off_ring[1] < min(0.0006, off_ring[0] / 3)


def tee_on_a_table(rng):
    """A T-joint along x ending at x = 0: flange top z = 0 left of the web (y in -30..0 mm), the
    web's face y = 0 up to z = 30 mm; the table 10 mm below the flange seen past its end (x 0..40
    mm). The fillet runs along x at y = z = 0."""
    x, y = grid((-0.08, 0.0), (-0.03, 0.0))
    flange = np.column_stack([x, y, np.zeros(len(x))])
    x, z = grid((-0.08, 0.0), (0.0008, 0.03))
    web = np.column_stack([x, np.zeros(len(x)), z])
    x, y = grid((0.0, 0.04), (-0.03, 0.03))
    table = np.column_stack([x, y, np.full(len(x), -0.01)])
    points = np.vstack([flange, web, table])
    return points + rng.normal(0, 0.0001, points.shape)


class CountingSurface:
    """A FineSurface counting the sections fitted (fit and fit_many)."""

    def __init__(self, surface):
        self.surface, self.fitted = surface, 0

    def __getattr__(self, name):
        return getattr(self.surface, name)

    def fit(self, *args, **kwargs):
        self.fitted += 1
        return self.surface.fit(*args, **kwargs)

    def fit_many(self, centres, *args, **kwargs):
        self.fitted += len(centres)
        return self.surface.fit_many(centres, *args, **kwargs)


def test_a_fillet_stops_where_the_camera_sees_past_the_parts_end_without_seeking_it_across_a_hole(rng):
    """Past the tee's end the camera sees the table 10 mm below the seam line: the part ends there,
    and the fillet stops without the sections of a hole search (max_skip_m to max_hole_m ahead,
    one step apart). Without a single camera (no view) nothing says it is no hole: those sections
    are fitted before the fillet stops at its last fit (and is not run on to the part's end)."""
    from scipy.spatial import cKDTree

    from weldseam.config import PlanConfig
    from weldseam.pipeline.occlusion import ViewBuffer
    from weldseam.pipeline.section import FineSurface, section_params

    points = tee_on_a_table(rng)
    axis = -np.array([0.0, -1.0, 1.0]) / np.sqrt(2)  # into the corner, on the bisector
    x = np.arange(-0.075, -0.055, STEP_M)
    seam = TracedSeam(np.column_stack([x, np.zeros(len(x)), np.zeros(len(x))]), np.tile(axis, (len(x), 1)), False,
                      JointKind.FILLET, 1.0)
    params = replace(ExtendConfig(), step_m=STEP_M, max_hole_m=0.05)
    view = ViewBuffer.build(points, np.array([0.0, -0.25, 0.35]), 0.001)
    seen = CountingSurface(FineSurface(points, cKDTree(points), section_params(PlanConfig()), view))
    stopped = extend_seam(seam, seen, params).positions_m
    assert -0.006 < stopped[:, 0].max() < 0.001, "to the tee's end, not beyond it"
    assert np.abs(stopped[:, 1:]).max() < 0.001, "in the corner"
    blind = CountingSurface(FineSurface(points, cKDTree(points), section_params(PlanConfig()), None))
    fitted = extend_seam(seam, blind, params).positions_m  # not run on: nothing says the part ends
    assert len(fitted) <= len(stopped) and np.array_equal(fitted, stopped[: len(fitted)])
    assert blind.fitted - seen.fitted >= round((params.max_hole_m - params.max_skip_m) / STEP_M)


def tee_extended(points, view_from=(0.0, -0.25, 0.35)):
    """The tee's fillet (tee_on_a_table) traced over x -75..-55 mm, extended with a single camera."""
    from scipy.spatial import cKDTree

    from weldseam.config import PlanConfig
    from weldseam.pipeline.occlusion import ViewBuffer
    from weldseam.pipeline.section import FineSurface, section_params

    axis = -np.array([0.0, -1.0, 1.0]) / np.sqrt(2)
    x = np.arange(-0.075, -0.055, STEP_M)
    seam = TracedSeam(np.column_stack([x, np.zeros(len(x)), np.zeros(len(x))]), np.tile(axis, (len(x), 1)), False,
                      JointKind.FILLET, 1.0)
    view = ViewBuffer.build(points, np.array(view_from), 0.001)
    surface = FineSurface(points, cKDTree(points), section_params(PlanConfig()), view)
    return extend_seam(seam, surface, replace(ExtendConfig(), step_m=STEP_M, max_hole_m=0.05))


def test_at_the_parts_end_the_seam_runs_on_to_it_where_the_last_sections_fail():
    """The sections within a few mm of the tee's end fail (their window reaches past its end face):
    the fits stop 3 mm short on three of four scans. Seeing past the part's end, the seam is run on
    along its line to where the joint's two faces end, bridged."""
    run_out = 0
    for seed in range(4):
        extended_seam = tee_extended(tee_on_a_table(np.random.default_rng(seed)))
        positions, flags = extended_seam.positions_m, extended_seam.point_flags
        assert -0.0015 < positions[:, 0].max() < 0.0005, "on to the tee's end, not beyond it"
        assert np.abs(positions[:, 1:]).max() < 0.0005, "in the corner"
        run_out += bool(flags[-1] & PointFlag.BRIDGED)
    assert run_out >= 3, "what no section fitted is marked bridged"


def test_a_seam_whose_joint_ends_before_the_part_does_is_not_run_on_to_the_parts_end(monkeypatch, rng):
    """The web ends 10 mm before the flange does: past it the flange alone goes on to the part's
    end, and the seam is not run on over it (the run-out adds nothing to where the fits stop)."""
    points = tee_on_a_table(rng)
    web = points[:, 2] > 0.0005
    points = points[~(web & (points[:, 0] > -0.01))]
    positions = tee_extended(points).positions_m
    monkeypatch.setattr(extend, "_run_out_step", lambda extension, end, template: None)
    assert np.array_equal(positions, tee_extended(points).positions_m)


def test_a_hole_on_an_inside_corners_line_is_the_stretch_without_data_between_its_edges():
    """A seam line 24 mm across a hole (1.5 mm apart). An inside corner's seam point lies on the
    part's surfaces, and the data there goes on from the hole's edge for a few mm where the sections
    fail: the line is empty between; a groove's seam line, in the air over its opening, is not."""
    from scipy.spatial import cKDTree

    from weldseam.config import PlanConfig
    from weldseam.pipeline.holes import _empty
    from weldseam.pipeline.occlusion import ViewBuffer
    from weldseam.pipeline.section import FineSurface, section_params

    line = np.column_stack([np.arange(0.0015, 0.024, 0.0015), np.zeros(15), np.zeros(15)])
    edge = np.column_stack([np.arange(0.019, 0.0245, 0.0005), np.zeros(12), np.zeros(12)])  # the last 5 mm
    far = np.column_stack([np.arange(-0.02, 0.0, 0.0005), np.zeros(40), np.zeros(40)])  # the surface before

    def surface(points, view=None):
        return FineSurface(points, cKDTree(points), section_params(PlanConfig()), view)

    points = np.vstack([far, edge])
    assert _empty(line, JointKind.FILLET, surface(points), max_edge_m=0.012)
    assert not _empty(line, JointKind.V_GROOVE, surface(points), max_edge_m=0.012), "a plate crosses a groove's line"
    assert not _empty(line, JointKind.FILLET, surface(points), max_edge_m=0.004), "more data at an edge than a skip"
    along = np.column_stack([np.arange(0.0, 0.025, 0.0005), np.zeros(50), np.zeros(50)])
    assert not _empty(line, JointKind.FILLET, surface(np.vstack([points, along])), max_edge_m=0.012), "no hole"
    # The camera above sees the table 10 mm below the line: the part has ended, no hole.
    table_x, table_y = grid((-0.01, 0.035), (-0.01, 0.01), pitch=0.0005)
    table = np.column_stack([table_x, table_y, np.full(len(table_x), -0.01)])
    seen = np.vstack([points, table])
    view = ViewBuffer.build(seen, np.array([0.012, 0.0, 0.4]), 0.0005)
    assert not _empty(line, JointKind.FILLET, surface(seen, view), max_edge_m=0.012)
    nothing_past = ViewBuffer.build(points, np.array([0.012, 0.0, 0.4]), 0.0005)
    assert _empty(line, JointKind.FILLET, surface(points, nothing_past), max_edge_m=0.012)


def test_an_inside_corner_is_carried_across_a_hole_only_onto_a_corner_with_both_faces_seen():
    from weldseam.pipeline.holes import _measured

    one_face = SectionFit(JointKind.FILLET, np.zeros(3), np.array([0.0, 0.0, -1.0]), flags=int(PointFlag.ONE_FACE))
    assert not _measured(JointKind.FILLET, one_face), "maybe a surface ending in a shadow"
    assert _measured(JointKind.FILLET, replace(one_face, flags=0))
    assert _measured(JointKind.V_GROOVE, replace(one_face, kind=JointKind.V_GROOVE))


class PipeFootFits:
    """A stand-in surface along the foot of a pipe (radius 26 mm, axis z) standing on a plate:
    fit_many gives a fit of both faces (the included angle 90 degrees and the torch axis the
    bisector, each with 2 degrees of noise in each direction) where the section lies less than
    `seen_m` of arc from the seam's start, and beyond it a corner with one face unseen (near the
    pipe's silhouette)."""

    radius_m = 0.026

    def __init__(self, rng, seen_m):
        self.rng, self.seen_m = rng, seen_m

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        fits = []
        for centre in centres:
            angle = np.arctan2(centre[1], centre[0])
            out = np.array([np.cos(angle), np.sin(angle), 0.0])
            tilt = self.rng.normal(0.0, np.radians(2.0), 3)
            axis = -(out + [0.0, 0.0, 1.0]) / np.sqrt(2) + tilt
            axis /= np.linalg.norm(axis)
            full = angle * self.radius_m < self.seen_m
            fits.append(SectionFit(JointKind.FILLET, centre, axis, JointGeometry(included_deg=90.0 + self.rng.normal(0, 2)),
                                   flags=0 if full else int(PointFlag.ONE_FACE)))  # fmt: skip
        return fits


def test_a_pipes_ruling_is_taken_from_the_full_fits_spread_over_the_seam(rng):
    """Toward a standing pipe's silhouette the re-fitted sections see one face: of the 8 sections
    over the last 32 mm of an 80 mm seam, the first 4 (14 mm) hold full fits; their normals turn
    30 degrees, and their noise tilts the pipe's axis from them up to 20 degrees, half the time
    over 4. With the 8 sections over the 32 mm before, the pipe's face is carried on along
    its axis within 4 degrees in each of 20 draws of the noise (99 % of 200 within 3.2)."""
    radius_m = PipeFootFits.radius_m
    angles = np.arange(0.0, 0.08 / radius_m, STEP_M / radius_m)
    out = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))])
    positions, axes = radius_m * out, -(out + [0.0, 0.0, 1.0]) / np.sqrt(2)
    off_axis_deg = []
    for _ in range(20):
        end = extend.SeamEnd(list(positions), list(axes), [False] * len(positions), *end_curve(positions), STEP_M,
                             0.012, last_full=ends.last_full(positions, None))  # fmt: skip
        template = end.corner(Extension(PipeFootFits(rng, seen_m=0.062), JointKind.FILLET, ExtendConfig()))
        # Counter-clockwise seen from above, the torch pointing in and down: the pipe is on the right.
        off_axis_deg.append(np.degrees(np.arccos(template.right @ [0.0, 0.0, 1.0])))
    assert max(off_axis_deg) < 4.0
