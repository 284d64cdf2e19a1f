"""A seam of another kind lying inside a V-groove's opening is the groove's own geometry."""

import numpy as np
from scipy.spatial import cKDTree

from tests.conftest import planned_broad_case
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.nested import inside, outside_grooves
from weldseam.pipeline.trace import TracedSeam


def seam(kind, x_m, z_m, half_opening_m=0.0, length_m=0.1):
    """A straight seam along y at (x_m, z_m), torch axis straight down."""
    y = np.linspace(0.0, length_m, 41)
    points = np.column_stack([np.full(len(y), x_m), y, np.full(len(y), z_m)])
    return TracedSeam(points, np.tile([0.0, 0.0, -1.0], (len(y), 1)), False, kind, 1.0, half_opening_m=half_opening_m)


GROOVE = seam(JointKind.V_GROOVE, 0.0, 0.010, half_opening_m=0.005)  # a 10 mm opening at z 10 mm


def test_a_lap_at_the_grooves_root_is_inside_it_and_dropped():
    """A 'lap' 2.6 mm across and 4 mm down from the opening's centre: the V's wall and bottom."""
    root = seam(JointKind.LAP, 0.0026, 0.006)
    assert inside(root, GROOVE)
    assert outside_grooves([GROOVE, root]) == [GROOVE]


def test_seams_beside_above_or_past_the_groove_are_kept():
    beside = seam(JointKind.FILLET, 0.012, 0.010)  # 12 mm across: past the edge
    above = seam(JointKind.LAP, 0.0, 0.013)  # 3 mm above the opening
    past_end = seam(JointKind.LAP, 0.002, 0.007, length_m=0.1)
    past_end = TracedSeam(past_end.positions_m + [0.0, 0.15, 0.0], past_end.torch_axes, False, JointKind.LAP, 1.0)
    other_groove = seam(JointKind.V_GROOVE, 0.002, 0.008, half_opening_m=0.004)
    seams = [GROOVE, beside, above, past_end, other_groove]
    assert not any(inside(s, GROOVE) for s in (beside, above, past_end))
    assert outside_grooves(seams) == seams


def test_a_v_groove_beside_a_square_butt_gives_its_two_seams_and_no_lap_at_the_vs_root():
    """The project's own v_groove_and_square_butt scene, seed 1: sought again in a narrow window, the
    V's wall and root read as a 95 mm lap 4.8 mm from the V's seam, which split the V in three. It
    lies inside the V's opening: the paths are the V and the square butt, each whole."""
    scene, state = planned_broad_case("v_groove_and_square_butt", 1, "split")
    assert sorted(seam.joint.value for seam in state.seams) == ["square_butt", "v_groove"]
    for truth in scene.seams:
        along = cKDTree(truth.points_m)
        assert min(np.median(along.query(seam.positions_m)[0]) for seam in state.seams) < 0.0005
