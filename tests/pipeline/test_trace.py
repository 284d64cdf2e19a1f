import numpy as np

from weldseam.config import TraceConfig
from weldseam.pipeline.joints import JointGeometry, JointKind
from weldseam.pipeline.order import Chain
from weldseam.pipeline.section import PointFlag, SectionFit
from weldseam.pipeline.trace import TracedSeam, consistent, inside_traced, on_fits, trace_chain

STEP_M = 0.002


def test_a_line_along_a_traced_grooves_edge_is_inside_it_and_a_line_beside_it_is_not():
    along = np.arange(0.0, 0.1, STEP_M)
    seam = TracedSeam(
        np.column_stack([along, np.zeros_like(along), np.zeros_like(along)]), np.tile([0.0, 0.0, -1.0], (50, 1)),
        False, JointKind.V_GROOVE, 1.0, half_opening_m=0.004,
    )
    edge_line = np.column_stack([along[5:40:3], np.full(12, 0.0085), np.zeros(12)])  # 4 + 4.5 mm aside
    assert inside_traced(edge_line, [seam], beside_m=0.006)
    assert not inside_traced(edge_line + [0.0, 0.002, 0.0], [seam], beside_m=0.006), "a parallel line 10.5 mm off"
    beyond = np.column_stack([np.arange(0.112, 0.122, 0.002), np.full(5, 0.0085), np.zeros(5)])
    past_the_end = np.vstack([edge_line, beyond])  # 30 % of it past the seam's end
    assert not inside_traced(past_the_end, [seam], beside_m=0.006), "a line going on past the seam's end"
    assert not inside_traced(edge_line, [], beside_m=0.006)




def test_a_line_mostly_inside_a_traced_seam_is_inside_it():
    along = np.arange(0.0, 0.1, STEP_M)
    seam = TracedSeam(np.column_stack([along, np.zeros(50), np.zeros(50)]), np.tile([0.0, 0.0, -1.0], (50, 1)),
                      False, JointKind.V_GROOVE, 1.0, half_opening_m=0.004)
    longer = np.column_stack([np.arange(0.0, 0.115, STEP_M), np.full(58, 0.005), np.zeros(58)])  # 86 % beside it
    assert inside_traced(longer, [seam], beside_m=0.006)
    half_outside = np.column_stack([np.arange(0.05, 0.15, STEP_M), np.full(50, 0.005), np.zeros(50)])
    assert not inside_traced(half_outside, [seam], beside_m=0.006)


class ModelsSurface:
    """A stand-in FineSurface whose sections along y = 0 fit a V-groove at the section centre,
    except every third, which another model (a lap 3 mm aside) explains better unless only the
    V-groove is sought."""

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        fits = []
        for centre in centres:
            other = round(centre[0] / STEP_M) % 3 == 0 and (kinds is None or JointKind.LAP in kinds)
            kind, point = (JointKind.LAP, centre + [0.0, 0.003, 0.0]) if other else (JointKind.V_GROOVE, centre)
            fits.append(SectionFit(kind, point, np.array([0.0, 0.0, -1.0])))
        return fits


def test_sections_another_model_explains_better_are_fitted_again_as_the_chains_joint():
    along = np.arange(0.0, 0.1, STEP_M)
    chain = Chain(np.column_stack([along, np.zeros_like(along), np.zeros_like(along)]), False)
    axes = np.tile([0.0, 0.0, -1.0], (len(along), 1))
    (seam,) = trace_chain(chain, axes, {}, ModelsSurface(), TraceConfig())
    assert seam.joint == JointKind.V_GROOVE
    assert len(seam.positions_m) == len(along) and np.abs(seam.positions_m[:, 1]).max() < 1e-12


class ValleySurface:
    """A stand-in FineSurface with a corner of 140 degrees along y = 0: a section within 2 mm of it
    fits it (the seam point on it, right under the section's centre); one farther off fits it only
    every other time (the corner is lost in the ripple when the window is off it)."""

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        fits = []
        for centre in centres:
            found = abs(centre[1]) <= 0.002 or round(centre[0] / STEP_M) % 2 == 0
            point = np.array([centre[0], 0.0, 0.0])
            fits.append(SectionFit(JointKind.FILLET if found else None, point, np.array([0.0, 0.0, -1.0]),
                                   JointGeometry(included_deg=140.0)))
        return fits


class OneFaceSurface:
    """A stand-in FineSurface whose every section is an inside corner with one face unseen along
    y = 0, with `flags`."""

    def __init__(self, flags):
        self.flags = flags

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        return [SectionFit(JointKind.FILLET, np.array([centre[0], 0.0, 0.0]), np.array([0.0, 0.0, -1.0]),
                           JointGeometry(included_deg=90.0, faces_seen=1), flags=self.flags) for centre in centres]


def test_corners_placed_from_an_outline_alone_are_no_seam():
    """A T-joint seen from above is traced from its one-face corners; the edge of a standing
    pipe's shadow, whose corners are placed from the pipe's outline, is not."""
    along = np.arange(0.0, 0.06, STEP_M)
    chain = Chain(np.column_stack([along, np.zeros_like(along), np.zeros_like(along)]), False)
    axes = np.tile([0.0, 0.0, -1.0], (len(along), 1))
    (seam,) = trace_chain(chain, axes, {}, OneFaceSurface(int(PointFlag.ONE_FACE)), TraceConfig())
    assert len(seam.positions_m) == len(along)
    assert trace_chain(chain, axes, {}, OneFaceSurface(int(PointFlag.ONE_FACE | PointFlag.OUTLINE)), TraceConfig()) == []


class StretchSurface:
    """A stand-in FineSurface whose sections fit a V-groove along y = 0 only for x in [start, stop)
    (m); it counts the sections it fits."""

    def __init__(self, start_m, stop_m):
        self.start_m, self.stop_m, self.fitted = start_m, stop_m, 0

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        self.fitted += len(centres)
        return [SectionFit(JointKind.V_GROOVE if self.start_m <= centre[0] < self.stop_m else None, centre,
                           np.array([0.0, 0.0, -1.0])) for centre in centres]


def test_a_long_chain_where_few_coarse_sections_fit_is_given_up_before_the_rest_are_fitted():
    along = np.arange(0.0, 0.2, STEP_M)  # 100 sections
    chain = Chain(np.column_stack([along, np.zeros_like(along), np.zeros_like(along)]), False)
    axes = np.tile([0.0, 0.0, -1.0], (len(along), 1))
    edge = StretchSurface(0.0, 0.02)  # a tenth of it fits
    assert trace_chain(chain, axes, {}, edge, TraceConfig()) == []
    assert edge.fitted == 25, "every fourth section only"
    seam_part = StretchSurface(0.0, 0.13)  # 65 %: a seam, every section fitted
    (seam,) = trace_chain(chain, axes, {}, seam_part, TraceConfig())
    assert seam_part.fitted == 100 and len(seam.positions_m) == 65
    short = Chain(chain.points[:10], False)  # too short to judge from a few sections: all fitted
    few = StretchSurface(0.0, 0.002)
    assert trace_chain(short, axes[:10], {}, few, TraceConfig()) == [] and few.fitted == 10


def test_a_chain_beside_the_seam_its_sections_find_is_traced_again_on_that_seam():
    along = np.arange(0.0, 0.06, STEP_M)
    beside = Chain(np.column_stack([along, np.full(len(along), 0.004), np.zeros(len(along))]), False)
    axes = np.tile([0.0, 0.0, -1.0], (len(along), 1))
    assert not trace_chain(beside, axes, {}, ValleySurface(), TraceConfig()), "half its sections fit from beside"
    (seam,) = trace_chain(beside, axes, {}, ValleySurface(), TraceConfig(), follow_fits=True)
    assert len(seam.positions_m) == len(along), "every section fits once across the line they found"
    assert np.abs(seam.positions_m[:, 1]).max() < 1e-12
    moved = on_fits(beside, ValleySurface().fit_many(beside.points, None, None, None), JointKind.FILLET)
    assert np.abs(moved.points[:, 1]).max() < 1e-12 and np.allclose(moved.points[:, 0], along)
    on_it = Chain(beside.points - [0.0, 0.004, 0.0], False)
    assert on_fits(on_it, ValleySurface().fit_many(on_it.points, None, None, None), JointKind.FILLET) is None


class CountingValleySurface(ValleySurface):
    """ValleySurface counting the sections it fits."""

    fitted = 0

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        self.fitted += len(centres)
        return super().fit_many(centres, travel, axes, lateral, kinds)


def test_a_chain_beside_a_traced_seam_whose_sections_find_only_that_seam_is_given_up_after_its_coarse_pass():
    along = np.arange(0.0, 0.2, STEP_M)  # 100 sections, 4 mm off the valley
    beside = Chain(np.column_stack([along, np.full(len(along), 0.004), np.zeros(len(along))]), False)
    axes = np.tile([0.0, 0.0, -1.0], (len(along), 1))
    on_valley = beside.points - [0.0, 0.004, 0.0]
    traced = TracedSeam(on_valley, axes, False, JointKind.FILLET, 1.0)
    surface = CountingValleySurface()
    assert trace_chain(beside, axes, {}, surface, TraceConfig(), follow_fits=True, traced=[traced], beside_m=0.006) == []
    assert surface.fitted == 25, "every fourth section only"
    half = TracedSeam(on_valley[:40], axes[:40], False, JointKind.FILLET, 1.0)  # 60 % of it still new
    surface = CountingValleySurface()
    (seam,) = trace_chain(beside, axes, {}, surface, TraceConfig(), follow_fits=True, traced=[half], beside_m=0.006)
    # What the half traced, and beside_m past its end, is not traced again: the seam is the rest.
    assert np.array_equal(seam.positions_m, on_valley[-len(seam.positions_m):]) and surface.fitted > 100
    assert abs(seam.positions_m[0, 0] - (along[39] + 0.006)) <= STEP_M / 2
    on_it = Chain(on_valley, False)
    (seam,) = trace_chain(on_it, axes, {}, CountingValleySurface(), TraceConfig(), traced=[traced], beside_m=0.006)
    assert len(seam.positions_m) == len(along), "a chain on its joint is judged by where it lies, before (inside_traced)"


def test_a_shallow_corners_points_may_scatter_farther_across_than_a_square_ones():
    along = np.arange(0.0, 0.03, STEP_M)
    positions = np.column_stack([along, np.zeros(len(along)), np.zeros(len(along))])
    positions[7, 1] = 0.0025  # 2.5 mm across
    axes = np.tile([0.0, 0.0, -1.0], (len(along), 1))
    square = JointGeometry(included_deg=90.0).across_spread
    shallow = JointGeometry(included_deg=140.0).across_spread
    assert not consistent(positions, axes, 0.0015 * square, 8.0)[7]
    assert consistent(positions, axes, 0.0015 * shallow, 8.0)[7]
    assert abs(shallow - 1 / np.tan(np.radians(20.0))) < 1e-9 and square == 1.0
    assert JointGeometry(opening_m=0.012, included_deg=120.0).across_spread == 1.0, "a groove's point is between edges"
    assert JointGeometry(included_deg=140.0, faces_seen=1).across_spread == 1.0, "one face's end places the corner"


def test_a_seam_is_sampled_evenly_from_its_first_point_to_its_last():
    seam = TracedSeam(np.zeros((29, 3)), np.tile([0.0, 0.0, -1.0], (29, 1)), False, JointKind.V_GROOVE, 1.0)
    assert seam.samples(15).tolist() == list(range(0, 29, 2))
    assert seam.samples(40).tolist() == list(range(29))  # never more than it has


def test_two_pieces_end_to_end_take_the_longer_ones_joint_and_weigh_the_rest_by_points():
    from weldseam.pipeline.trace import Hole, end_to_end

    def piece(x_from, count, joint, confidence, hole=()):
        x = x_from + 0.002 * np.arange(count)
        return TracedSeam(np.column_stack([x, np.zeros(count), np.zeros(count)]), np.tile([0.0, 0.0, -1.0], (count, 1)),
                          False, joint, confidence, holes=hole, half_opening_m=0.004, sources=frozenset({count}))  # fmt: skip

    earlier = Hole((0.01, 0.0, 0.0), 0.004)
    a, b = piece(0.0, 30, JointKind.V_GROOVE, 1.0, (earlier,)), piece(0.07, 10, JointKind.BEVEL, 0.6)
    between = (np.array([[0.064, 0.0, 0.0]]), np.array([[0.0, 0.0, -1.0]]), np.array([4]))
    joined = end_to_end(a, between, b)
    assert joined.joint == JointKind.V_GROOVE and joined.confidence == 0.9  # 0.75 x 1.0 + 0.25 x 0.6
    assert len(joined.positions_m) == 41 and np.all(np.diff(joined.positions_m[:, 0]) > 0)
    assert joined.point_flags.tolist() == [0] * 30 + [4] + [0] * 10
    assert joined.holes == (earlier,) and joined.sources == frozenset({30, 10})
    assert np.array_equal(joined.reversed().positions_m, joined.positions_m[::-1])


class TwoJointsSurface:
    """A stand-in FineSurface: a fillet along x at y = 0 (a clamp's foot, say), and 20 mm aside a
    corner that a section reaches only past x = `beyond_m` (its window then takes it instead)."""

    def __init__(self, beyond_m: float):
        self.beyond_m = beyond_m

    def fit_many(self, centres, travel, axes, lateral, kinds=None):
        aside = [[0.0, 0.02, 0.0] if centre[0] >= self.beyond_m else [0.0, 0.001, 0.0] for centre in centres]
        points = np.asarray(centres) + np.reshape(aside, (-1, 3))
        return [SectionFit(JointKind.FILLET, point, np.array([0.0, -0.7071, -0.7071])) for point in points]


def test_two_sections_that_find_joints_centimetres_apart_are_no_seam_and_a_short_seam_is_kept():
    """A short chain (two sections 3 mm apart) whose sections find joints 20 mm apart: too few to
    be outvoted as off their neighbours' line, but no seam (a seam crossing its chain at up to 60
    degrees lies at most twice as far along it); the same chain finding one joint is a piece."""
    chain = Chain(np.array([[0.0, 0.0, 0.0], [0.003, 0.0, 0.0]]), False)
    axes = np.tile([0.0, 0.0, -1.0], (2, 1))
    assert trace_chain(chain, axes, {}, TwoJointsSurface(beyond_m=0.002), TraceConfig()) == []
    (piece,) = trace_chain(chain, axes, {}, TwoJointsSurface(beyond_m=1.0), TraceConfig())
    assert len(piece.positions_m) == 2 and np.allclose(piece.positions_m[:, 1], 0.001)
    along = np.arange(0.0, 0.1, STEP_M)  # a long chain: split where its sections' joint changes
    long_chain = Chain(np.column_stack([along, np.zeros_like(along), np.zeros_like(along)]), False)
    pieces = trace_chain(long_chain, np.tile([0.0, 0.0, -1.0], (len(along), 1)), {}, TwoJointsSurface(0.05),
                         TraceConfig())
    assert len(pieces) == 2 and sum(len(p.positions_m) for p in pieces) >= 45
    assert np.allclose(pieces[0].positions_m[:, 1], 0.001) and np.allclose(pieces[1].positions_m[:, 1], 0.02)
