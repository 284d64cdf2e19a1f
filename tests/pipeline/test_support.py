import numpy as np
import pytest

from types import SimpleNamespace

from scipy.spatial import cKDTree

from tests.conftest import fillet_cloud
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.support import find_support_plane, off_support
from weldseam.pipeline.trace import TracedSeam

CAMERA = np.array([0.0, 0.3, 0.3])


def test_the_table_under_a_part_is_the_support_plane_with_its_normal_toward_the_camera(rng):
    points = fillet_cloud(rng, flange_m=0.0)  # a block (the web) standing on the table at z = 0
    centre, normal = find_support_plane(points, np.ones(len(points), bool), CAMERA, tolerance_m=0.002,
                                        below_fraction=0.05)  # fmt: skip
    assert abs(centre[2]) < 0.001 and normal[2] > 0.999


def test_a_plane_with_much_beyond_it_is_not_a_support():
    ticks = np.arange(0.0, 0.1, 0.002)
    x, y = (a.ravel() for a in np.meshgrid(ticks, ticks))
    wall = np.column_stack([x, y, np.zeros(x.size)])
    behind = np.column_stack([x, y, np.full(x.size, -0.05)])  # half the scan lies beyond the larger plane
    points = np.vstack([wall, behind[: len(behind) // 2]])
    assert find_support_plane(points, np.ones(len(points), bool), np.array([0.05, 0.05, 0.5]),
                              tolerance_m=0.002, below_fraction=0.05) is None  # fmt: skip


@pytest.mark.parametrize("joint, height_m, dropped", [
    (JointKind.FILLET, 0.0005, True), (JointKind.FILLET, 0.01, False),
    (JointKind.LAP, 0.0005, True),  # a plate lying on the table: the same step as a lap
    (JointKind.LAP, 0.008, False),  # a lap on a bottom plate 8 mm thick
    # A groove's point lies at its plates' surface: at the table's, the opening is in the table
    # (a slot, a line of missing pixels); in 3 mm plates lying on the table it is 3 mm above it.
    (JointKind.SQUARE_BUTT, 0.0005, True), (JointKind.V_GROOVE, 0.0005, True), (JointKind.V_GROOVE, 0.003, False),
])
def test_a_seam_on_the_support_plane_is_dropped(joint, height_m, dropped):
    line = np.column_stack([np.linspace(0, 0.1, 20), np.zeros(20), np.full(20, height_m)])
    seam = TracedSeam(line, np.tile([0.0, 0.0, -1.0], (20, 1)), False, joint, 1.0)
    support = (np.zeros(3), np.array([0.0, 0.0, 1.0]))
    nothing_beside = surface_of(np.ones((1, 3)))
    assert (off_support([seam], nothing_beside, support, tolerance_m=0.002) == []) == dropped


TABLE = (np.zeros(3), np.array([0.0, 0.0, 1.0]))


def surface_of(points):
    return SimpleNamespace(points=points, tree=cKDTree(points))


def grid(u_range, v_range, step=0.001):
    u, v = (a.ravel() for a in np.meshgrid(np.arange(*u_range, step), np.arange(*v_range, step)))
    return u, v


def seam_along_x(z_m, axis):
    line = np.column_stack([np.linspace(0.0, 0.1, 51), np.zeros(51), np.full(51, z_m)])
    return TracedSeam(line, np.tile(axis / np.linalg.norm(axis), (51, 1)), False, JointKind.V_GROOVE, 1.0)


def test_the_v_a_tilted_plate_forms_with_the_table_is_dropped():
    # A plate leaning at 30 degrees with its edge on the table along x: the valley between them
    # looks like a V groove, but one of its sides is the table.
    x, y = grid((0.0, 0.1), (-0.03, 0.0))
    table = np.column_stack([x, y, np.zeros(x.size)])
    x, s = grid((0.0, 0.1), (0.0, 0.03))
    plate = np.column_stack([x, s * np.cos(np.radians(30)), s * np.sin(np.radians(30))])
    seam = seam_along_x(0.0, np.array([0.0, np.sin(np.radians(15)), -1.0]))
    assert off_support([seam], surface_of(np.vstack([table, plate])), TABLE, tolerance_m=0.002) == []


def test_a_groove_between_plates_lying_on_the_table_is_kept():
    # Two 10 mm plates on the table with a 60 degree V between them (root 2 mm above the
    # table), its seam point at the plates' surface: the table shows beyond the plates, but
    # neither side of the groove is the table.
    x, y = grid((0.0, 0.1), (-0.05, 0.05))
    top = np.abs(y) >= 0.0046 + 0.001
    plates = np.column_stack([x[top], y[top], np.full(top.sum(), 0.01)])
    wall = np.abs(y) < 0.0056
    walls = np.column_stack([x[wall], y[wall], 0.002 + np.abs(y[wall]) / np.tan(np.radians(30))])
    xt, yt = grid((0.0, 0.1), (-0.1, -0.05))
    table = np.column_stack([xt, yt, np.zeros(xt.size)])
    seam = seam_along_x(0.01, np.array([0.0, 0.0, -1.0]))
    surface = surface_of(np.vstack([plates, walls, table]))
    assert len(off_support([seam], surface, TABLE, tolerance_m=0.002)) == 1


def test_a_corner_a_bar_forms_with_the_table_is_dropped_however_its_axis_leans():
    """A bar 14 mm high standing on the table along y, its side face at x = 0: a corner fitted
    3.5 mm up that face with the torch axis level (into the bar) has the table below it, not
    beside it across its lateral (which points up): the table is the surface on one side of it
    all the same, from 4 mm of it on."""
    y, z = grid((0.0, 0.1), (0.0, 0.014))
    face = np.column_stack([np.zeros(y.size), y, z])
    x, y = grid((0.0005, 0.03), (0.0, 0.1))
    table = np.column_stack([x, y, np.zeros(x.size)])
    line = np.column_stack([np.zeros(51), np.linspace(0.0, 0.1, 51), np.full(51, 0.0035)])
    seam = TracedSeam(line, np.tile([-1.0, 0.0, 0.0], (51, 1)), False, JointKind.LAP, 1.0)
    assert off_support([seam], surface_of(np.vstack([face, table])), TABLE, tolerance_m=0.002) == []
