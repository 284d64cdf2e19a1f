from dataclasses import replace

import numpy as np

from weldseam.pipeline.join import join_pieces, trim_overlaps
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import PointFlag
from weldseam.pipeline.trace import TracedSeam

DOWN = np.array([0.0, 0.0, -1.0])


def piece(points, joint=JointKind.V_GROOVE):
    points = np.asarray(points, float)
    return TracedSeam(points, np.tile(DOWN, (len(points), 1)), False, joint, 1.0)


def line(start, end, step=0.002):
    start, end = np.asarray(start, float), np.asarray(end, float)
    count = int(round(np.linalg.norm(end - start) / step)) + 1
    return start + np.linspace(0, 1, count)[:, None] * (end - start)


def join(seams):
    return join_pieces(seams, join_m=0.025, max_turn_deg=100.0, step_m=0.002)


def test_collinear_pieces_across_a_hole_join_into_one_seam_in_order():
    (seam,) = join([piece(line([0.06, 0, 0], [0.1, 0, 0])), piece(line([0, 0, 0], [0.05, 0, 0]))])
    x = seam.positions_m[:, 0]
    assert np.all(np.diff(x) > 0) or np.all(np.diff(x) < 0)
    assert np.isclose(abs(x[-1] - x[0]), 0.1)


def test_pieces_of_a_ring_close_into_one_loop():
    angles = np.linspace(0, 2 * np.pi, 180, endpoint=False)
    ring = 0.05 * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(180)])
    pieces = [piece(ring[5:60]), piece(ring[66:120]), piece(ring[126:176])]  # three gaps of ~10 mm
    (seam,) = join(pieces)
    assert seam.closed and len(seam.positions_m) == 159


def test_y_branches_stay_three_seams():
    arms = [piece(line([0.004 * np.cos(a), 0.004 * np.sin(a), 0], [0.06 * np.cos(a), 0.06 * np.sin(a), 0])) for a in (0, 2.2, 4.1)]
    assert len(join(arms)) == 3


def test_a_groove_over_a_block_edge_joins_through_the_bend():
    top = piece(line([0, 0.08, 0.1], [0, 0.003, 0.1]))
    side = piece(line([0, 0.0, 0.094], [0, 0.0, 0.02]))  # down the side, starting 6 mm below the edge
    (seam,) = join([top, side])
    assert len(seam.positions_m) == len(top.positions_m) + len(side.positions_m) + 1  # and the edge's corner
    assert np.min(np.linalg.norm(seam.positions_m - [0, 0, 0.1], axis=1)) < 1e-9


def test_pieces_far_either_side_of_a_bend_wait_for_the_extension_but_in_line_they_join():
    """Before the extension, a corner only within corner_join_m: the corner of two pieces' end lines
    misses the seam by their directions' error times the gap, and the gap stays unsampled."""
    top = piece(line([0, 0.08, 0.1], [0, 0.003, 0.1]))
    side_points = line([0, 0.0, 0.085], [0, 0.0, 0.07])  # 15 mm below the edge, 6 degrees off
    side = piece(side_points + np.array([0, -0.0015, 0]) * np.linspace(1, 0, len(side_points))[:, None])
    assert len(join_pieces([top, side], join_m=0.025, max_turn_deg=100.0, step_m=0.002, corner_join_m=0.012)) == 2
    (seam,) = join_pieces([top, side], join_m=0.025, max_turn_deg=100.0, step_m=0.002)  # as after the extension
    known = np.vstack([top.positions_m, side.positions_m])
    (corner,) = [p for p in seam.positions_m if np.min(np.linalg.norm(known - p, axis=1)) > 1e-9]
    assert np.linalg.norm(corner - [0, 0, 0.1]) > 0.001  # the lines' corner, off the edge
    far = piece(line([0, 0.18, 0.1], [0, 0.1, 0.1]))  # in line with the top piece, 20 mm on: joined straight
    assert len(join_pieces([top, far], join_m=0.025, max_turn_deg=100.0, step_m=0.002, corner_join_m=0.012)) == 1


def test_parallel_seams_do_not_join():
    assert len(join([piece(line([0, 0, 0], [0.1, 0, 0])), piece(line([0, 0.02, 0], [0.1, 0.02, 0]))])) == 2


def test_a_piece_beside_the_seams_line_is_not_joined_into_it():
    """Beside a tack weld a chain fits a groove 3.5 mm off the seam, its own line turned 45 degrees
    from the seam's, 15 mm past one piece's end: no piece of the seam. Set on the line, it is."""
    before, after = piece(line([0, 0, 0], [0.04, 0, 0])), piece(line([0.075, 0, 0], [0.12, 0, 0]))
    off = line([0.055, 0.0035, 0], [0.055 + 0.02 * np.cos(0.8), 0.0035 + 0.02 * np.sin(0.8), 0])
    seams = join([before, after, piece(off)])
    assert len(seams) == 3
    on_line = line([0.047, 0, 0], [0.068, 0, 0])
    (seam,) = join([before, after, piece(on_line)])
    assert np.abs(seam.positions_m[:, 1]).max() < 1e-9


def test_an_overlapping_trace_keeps_only_what_it_adds():
    longer, shifted = piece(line([0, 0, 0], [0.1, 0, 0])), piece(line([0.06, 0.001, 0], [0.13, 0.001, 0]))
    kept = trim_overlaps([shifted, longer], tolerance_m=0.004)
    assert len(kept) == 2
    added = kept[1].positions_m
    assert added[:, 0].min() > 0.1 and np.isclose(added[:, 0].max(), 0.13)


def test_a_bend_bridged_across_its_failed_sections_keeps_its_corner():
    # Over a block edge at the origin: the top run ends 5 mm before the edge, the side run
    # starts 5 mm below it. A straight bridge would cut the corner by 3.5 mm.
    top = piece(line([-0.06, 0, 0], [-0.005, 0, 0]))
    side = TracedSeam(line([0, 0, -0.005], [0, 0, -0.06]), np.tile([-1.0, 0, 0], (28, 1)), False, JointKind.V_GROOVE, 1.0)
    (seam,) = join([top, side])
    distances = np.linalg.norm(seam.positions_m, axis=1)
    corner = np.argmin(distances)
    assert distances[corner] < 1e-9
    assert np.allclose(seam.torch_axes[corner], np.array([-1.0, 0, -1.0]) / np.sqrt(2))  # bisects the faces


def test_a_short_piece_past_a_bend_is_reached_through_the_corner_not_across_it():
    # The top runs along +x to 8 mm before the block's edge at x = 0.1; all the side shows past
    # the edge is a 4 mm piece 10 mm down, too short to have a direction of its own. The chord
    # from the top's end to it would cut the corner by 6 mm.
    top, stub = piece(line([0.0, 0, 0], [0.092, 0, 0])), piece(line([0.1, 0, -0.010], [0.1, 0, -0.014]))
    (seam,) = join([top, stub])
    assert np.linalg.norm(seam.positions_m - [0.1, 0, 0], axis=1).min() < 1e-9  # the edge's corner
    assert np.all((np.abs(seam.positions_m[:, 2]) < 1e-9) | (np.abs(seam.positions_m[:, 0] - 0.1) < 1e-9))


def test_pieces_meeting_at_a_gentle_turn_get_no_corner_point():
    angles = np.linspace(0, 2 * np.pi, 180, endpoint=False)
    ring = 0.05 * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(180)])
    (seam,) = join([piece(ring[5:60]), piece(ring[66:120])])
    assert len(seam.positions_m) == 55 + 54
    assert np.allclose(np.linalg.norm(seam.positions_m, axis=1), 0.05)


def test_a_corner_traced_at_a_grooves_root_is_the_groove_not_a_seam_of_its_own():
    # A 24 mm wide, 10 mm deep V along x (torch axis -z, into the work): its root, 10 mm under
    # the opening, is a concave corner the fillet model also fits. A piece in line beyond the
    # groove's end is no part of it.
    groove = replace(piece(line([0, 0, 0], [0.1, 0, 0])), half_opening_m=0.012)
    root = piece(line([0.04, 0, -0.010], [0.06, 0, -0.010]), JointKind.FILLET)
    beyond = piece(line([0.115, 0, 0], [0.14, 0, 0]))
    kept = trim_overlaps([groove, root, beyond], tolerance_m=0.004)
    assert [len(seam.positions_m) for seam in kept] == [len(groove.positions_m), len(beyond.positions_m)]


def test_a_v_groove_and_a_bevel_piece_end_to_end_are_one_groove_of_the_longer_kind():
    """A bevel is a special case of the V-groove: where a stretch of a V-groove fits as a bevel
    (one wall looking square), its pieces still join, and the seam is what most of it is."""
    groove, bevel = piece(line([0.0, 0, 0], [0.09, 0, 0])), piece(line([0.1, 0, 0], [0.15, 0, 0]), JointKind.BEVEL)
    (seam,) = join([bevel, groove])
    assert seam.joint == JointKind.V_GROOVE and np.isclose(np.ptp(seam.positions_m[:, 0]), 0.15)
    fillet = piece(line([0.1, 0, 0], [0.15, 0, 0]), JointKind.FILLET)
    assert len(join([groove, fillet])) == 2  # a different joint stays apart


def test_corners_with_one_face_unseen_go_on_from_a_ring_only_along_it():
    """Past a standing pipe's silhouette the edge of its shadow passes for a corner whose wall is
    unseen, and runs straight off the ring along the line of sight: such a piece joins the ring's
    full fits only where it follows their curve."""
    radius = 0.047
    angles = np.arange(0.0, 1.2, 0.002 / radius)
    ring = radius * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))])
    full = piece(ring, JointKind.FILLET)
    one_face = np.full(12, int(PointFlag.ONE_FACE), np.uint8)
    on_ring = radius * np.column_stack([np.cos(a := 1.2 + 0.006 / radius + np.arange(12) * 0.002 / radius),
                                        np.sin(a), np.zeros(12)])  # fmt: skip
    tangent = np.array([-np.sin(1.2), np.cos(1.2), 0.0])
    off_ring = ring[-1] + np.outer(0.006 + np.arange(12) * 0.002, tangent)
    for points, joins in ((on_ring, True), (off_ring, False)):
        after = replace(piece(points, JointKind.FILLET), flags=one_face)
        seams = join([full, after])
        assert (len(seams) == 1) == joins
    assert np.abs(np.hypot(*off_ring[-1, :2]) - radius) > 0.003, "the straight piece ends well off the ring"


def test_a_rough_piece_past_a_seams_end_joins_only_along_its_curve():
    """Past a plate's end a loose bar lying against it gives grooves whose outline misses their
    points (rough), in line with the seam at first, then turning off it: such a piece joins the
    seam's full fits only where it follows their curve; a clean piece there joins."""
    seam = piece(line([0, 0, 0], [0.1, 0, 0]))
    turning = np.array([[0.112, 0.0012, 0], [0.115, 0.0025, 0], [0.118, 0.0045, 0], [0.121, 0.007, 0]])
    rough = np.full(len(turning), int(PointFlag.ROUGH), np.uint8)
    assert len(join([seam, replace(piece(turning), flags=rough)])) == 2
    assert len(join([seam, piece(turning)])) == 1
    in_line = line([0.11, 0, 0], [0.124, 0, 0])
    assert len(join([seam, replace(piece(in_line), flags=np.full(len(in_line), int(PointFlag.ROUGH), np.uint8))])) == 1


def test_a_zigzag_piece_is_joined_on_with_its_near_end_first():
    # Pieces traced on broad fillet_t 3 (with sight lines 20 mm past a face's end): a seam's end
    # (its point 214 at x = -26.4 mm, running on toward -x) and a 3-point piece 19-23 mm beyond it
    # whose middle point, a rough corner with one face unseen, lies 6 mm off: 12.8 mm of polyline
    # over 4.5 mm between its ends. Its "direction" runs across the seam; it has none of its own,
    # and goes on the seam's end near end first (x -45.3, -48.1, -49.5 mm), not far end first
    # (the path ran back 4 mm with a corner 0.7 mm off inserted before it).
    seam_end = np.array([[-26.43, 9.2, 8.45], [-22.14, 8.52, 8.51], [-19.58, 7.94, 8.36], [-17.45, 7.61, 8.35],
                         [-13.67, 7.26, 8.5], [-11.72, 6.84, 8.32], [-9.3, 6.35, 8.23], [-7.47, 6.15, 8.19]]) / 1000
    zigzag = np.array([[-49.49, 12.16, 8.43], [-48.14, 6.53, 11.39], [-45.31, 11.44, 8.35]]) / 1000
    axis = np.array([-0.1, -0.70, -0.705])
    pieces = [TracedSeam(points, np.tile(axis / np.linalg.norm(axis), (len(points), 1)), False, JointKind.FILLET, 1.0)
              for points in (seam_end, zigzag)]
    (joined,) = join_pieces(pieces, join_m=0.025, max_turn_deg=100.0, step_m=0.002)
    x = joined.positions_m[:, 0] if joined.positions_m[0, 0] > -0.03 else joined.positions_m[::-1, 0]
    assert np.all(np.diff(x) < 0.0005)  # on toward -x all the way: no step back


def test_a_short_piece_further_round_a_tight_ring_is_joined_along_it_not_through_a_corner():
    """A piece of a 30 mm ring and, 48 degrees further round (a saddle's flank hidden by its
    branch), a 3-point piece too short to have a direction of its own: reached along the first
    piece's end ray, turned to it, the seam would pass 9 mm outside the ring; the end's curve leads
    to it, so they are joined along the ring (every point on it), with no corner."""
    angles = np.radians(np.arange(0.0, 360.0, 4.0))
    ring = 0.03 * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))])
    (seam,) = join([piece(ring[:38]), piece(ring[49:52])])  # 0-148 and 196-204 degrees
    assert len(seam.positions_m) == 38 + 3
    assert np.allclose(np.linalg.norm(seam.positions_m, axis=1), 0.03)
