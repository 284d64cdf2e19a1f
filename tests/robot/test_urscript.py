from __future__ import annotations

import re

import numpy as np

from weldseam.robot.moves import Shaping, motion_plan
from weldseam.robot.urscript import urscript
from weldseam.types import WeldPath

DOWN = np.column_stack([np.cross([1.0, 0, 0], [0, 0, -1.0]), [1.0, 0, 0], [0, 0, -1.0]])


def arc(seam_id: int) -> WeldPath:
    angles = np.linspace(0.0, np.pi / 2, 400)
    positions = 0.05 * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(400)])
    return WeldPath(seam_id=seam_id, positions_m=positions, rotations=np.tile(DOWN, (400, 1, 1)))


def test_script_has_one_movel_per_waypoint_with_blends_and_arc_around_weld():
    plan = motion_plan([arc(0), arc(1)], Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0), arc_output=2, max_blend_m=0.001))
    lines = urscript(plan).splitlines()
    movels = [line for line in lines if line.strip().startswith("movel(")]
    assert len(movels) == sum(len(seam.weld_poses) + 2 for seam in plan.seams)
    on = [i for i, line in enumerate(lines) if line.strip() == "set_standard_digital_out(2, True)"]
    off = [i for i, line in enumerate(lines) if line.strip() == "set_standard_digital_out(2, False)"]
    assert len(on) == len(off) == 2
    for seam, on_index, off_index in zip(plan.seams, on, off, strict=True):
        weld = lines[on_index + 1 : off_index]
        assert len(weld) == len(seam.weld_poses) - 1
        blends = [float(re.search(r"r=([0-9.e+-]+)\)", line).group(1)) for line in weld]
        np.testing.assert_allclose(blends, seam.blend_radii_m[1:], rtol=1e-8)
        first = np.array([float(v) for v in re.search(r"p\[(.*?)\]", lines[on_index - 1]).group(1).split(",")])
        np.testing.assert_allclose(first, seam.weld_poses[0], atol=1e-9)
        assert lines[off_index + 1].strip().startswith("movel(")


def test_no_arc_output_means_no_digital_out():
    plan = motion_plan([arc(0)], Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0)))
    assert "set_standard_digital_out" not in urscript(plan)


def test_the_payload_is_left_alone_unless_given_and_then_comes_with_its_centre_of_gravity():
    untouched = urscript(motion_plan([arc(0)], Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0))))
    assert "set_payload" not in untouched
    given = Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0), payload_kg=1.25, payload_cog_m=(0.0, 0.01, 0.08))
    assert "  set_payload(1.25, [0, 0.01, 0.08])" in urscript(motion_plan([arc(0)], given)).splitlines()
