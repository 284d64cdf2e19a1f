import numpy as np
import pytest

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
    (JointKind.FILLET, 0.0005, True), (JointKind.FILLET, 0.01, False), (JointKind.V_GROOVE, 0.0005, False),
])
def test_only_a_corner_on_the_support_plane_is_dropped(joint, height_m, dropped):
    line = np.column_stack([np.linspace(0, 0.1, 20), np.zeros(20), np.full(20, height_m)])
    seam = TracedSeam(line, np.tile([0.0, 0.0, -1.0], (20, 1)), False, joint, 1.0)
    support = (np.zeros(3), np.array([0.0, 0.0, 1.0]))
    assert (off_support([seam], support, tolerance_m=0.002) == []) == dropped
