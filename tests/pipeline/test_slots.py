"""Slots against analytic clouds: two faces beside a groove line, the right one flat (z = 0 for
x > width / 2), the left one turned `turn_deg` up from it, a slot between them whose far wall is
seen down to 14 mm; extruded 60 mm along y. The seam runs along y at the slot, torch axis -z."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from weldseam.config import PlanConfig
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import FineSurface, section_params
from weldseam.pipeline.slots import in_line_seams, sides_turn_deg, slot
from weldseam.pipeline.trace import TracedSeam

REACH_M = PlanConfig().section.half_width_m


def slot_height(x, turn_deg, width=0.005):
    """Height (m) of the profile at x (m): see the module docstring."""
    left_face = np.where(x < -width / 2, np.tan(np.radians(turn_deg)) * (-x - width / 2), 0.0)
    return np.where(np.abs(x) <= width / 2, -0.014 * (x + width / 2) / width - 0.002, left_face)


def slot_surface(rng, turn_deg, pitch=0.001):
    x, y = (a.ravel() for a in np.meshgrid(np.arange(-0.03, 0.03, pitch), np.arange(0.0, 0.06, pitch)))
    points = np.column_stack([x, y, slot_height(x, turn_deg) + rng.normal(0.0, 0.0002, x.size)])
    return FineSurface(points, cKDTree(points), section_params(PlanConfig()))


def seam_along_slot(joint=JointKind.V_GROOVE):
    line = np.column_stack([np.zeros(25), np.linspace(0.005, 0.055, 25), np.zeros(25)])
    return TracedSeam(line, np.tile([0.0, 0.0, -1.0], (25, 1)), False, joint, 1.0, half_opening_m=0.0025)


@pytest.mark.parametrize("turn_deg", [0.0, 6.0, 15.0, 30.0])
def test_the_turn_between_the_sides_is_measured(rng, turn_deg):
    x = np.sort(rng.uniform(-0.025, 0.025, 400))
    h = slot_height(x, turn_deg) + rng.normal(0.0, 0.0002, len(x))
    assert sides_turn_deg(x, h, -0.0025, 0.0025, REACH_M) == pytest.approx(turn_deg, abs=1.0)


def test_a_few_stray_points_below_a_side_do_not_turn_it(rng):
    x = np.sort(rng.uniform(-0.025, 0.025, 400))
    h = slot_height(x, 0.0) + rng.normal(0.0, 0.0002, len(x))
    stray = (x > 0.008) & (x < 0.011)  # a plate's edge seen 10 mm below, inside the window
    h[stray] -= 0.010
    assert sides_turn_deg(x, h, -0.0025, 0.0025, REACH_M) < 2.0


def test_a_side_too_narrow_to_set_a_direction_is_not_measured(rng):
    x = np.sort(rng.uniform(-0.025, 0.005, 300))  # nothing right of the slot past 2.5 mm
    assert sides_turn_deg(x, slot_height(x, 20.0), -0.0025, 0.0025, REACH_M) is None


@pytest.mark.parametrize("joint", [JointKind.V_GROOVE, JointKind.BEVEL, JointKind.SQUARE_BUTT])
def test_a_groove_between_sides_turned_25_degrees_is_a_slot_and_dropped(rng, joint):
    """A block's side and a clamp's post turned 25 degrees to it, a slot between: no butt joint."""
    seam = seam_along_slot(joint)
    assert slot(seam, slot_surface(rng, 25.0), REACH_M)
    assert in_line_seams([seam], slot_surface(rng, 25.0), REACH_M) == []


@pytest.mark.parametrize("turn_deg", [0.0, 6.0])
def test_a_groove_between_plates_in_line_or_bent_a_little_is_kept(rng, turn_deg):
    seam = seam_along_slot()
    assert in_line_seams([seam], slot_surface(rng, turn_deg), REACH_M) == [seam]


def test_a_corner_between_turned_faces_is_no_butt_joint_and_is_kept(rng):
    """A fillet's faces turn by its included angle: the rule reads butt joints only."""
    seam = seam_along_slot(JointKind.FILLET)
    assert not slot(seam, slot_surface(rng, 25.0), REACH_M)


def test_a_clamp_post_beside_a_block_gives_no_seam_and_the_groove_is_kept():
    """The project's own broad-world block with a V-groove (block_groove, seed 1) has a clamp on its
    top whose post stands a few mm beside the block: the slot between them was a second, 25 mm
    V-groove. Now the one path is the groove, and the candidate rejected as a slot lies at the post."""
    from weldseam.pipeline.candidates import Rejection
    from weldseam.pipeline.run import run_steps
    from weldseam.synthetic.catalog import draw_case
    from weldseam.types import Scan

    scene, scan = draw_case("block_groove", 1, broad=True)
    state = run_steps(Scan(points_m=scan.points_m, camera_origin_m=scan.camera_origin_m, source="block_groove_1"),
                      PlanConfig(), last="split")  # fmt: skip
    truth = cKDTree(np.vstack([seam.points_m for seam in scene.seams]))
    assert len(state.seams) == 1 and np.median(truth.query(state.seams[0].positions_m)[0]) < 0.0005
    slots = [np.array(c.centre_m) for c in state.chain_candidates if c.rejection == Rejection.SLOT]
    assert slots
    for centre in slots:
        gaps = [np.linalg.norm(np.maximum(0.0, np.maximum(f.bounds[0] - centre, centre - f.bounds[1])))
                for f in scene.fixtures]  # fmt: skip
        assert min(gaps) < 0.01  # beside a fixture (the clamp's post)
