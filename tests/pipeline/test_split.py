from dataclasses import replace

import numpy as np
import pytest

from tests.pipeline.test_join import line, piece
from weldseam.config import SplitConfig
from weldseam.pipeline.joints import JointKind
from weldseam.pipeline.section import PointFlag
from weldseam.pipeline.split import split_at_junctions, split_seams


def test_a_seam_is_split_where_another_ends_on_it():
    through, stem = piece(line([0, 0, 0], [0.1, 0, 0])), piece(line([0.05, 0.003, 0], [0.05, 0.06, 0]))
    seams = split_at_junctions([through, stem], tolerance_m=0.0125)
    assert len(seams) == 3
    ends = sorted(round(s.positions_m[:, 0].max(), 3) for s in seams if np.ptp(s.positions_m[:, 0]) > 0.01)
    assert ends == [0.05, 0.1]


def test_a_stub_too_short_to_be_a_seam_does_not_split_one():
    through = piece(line([0, 0, 0], [0.1, 0, 0]))
    stub = piece(line([0.05, 0.003, 0], [0.05, 0.0205, 0]))  # 17.5 mm: past a branch's 15, short of a seam's 20
    seams = split_seams([through, stub], [], SplitConfig(), step_m=0.002)
    assert len(seams) == 1 and np.array_equal(seams[0].positions_m, through.positions_m)


def test_a_seam_mostly_interpolated_across_a_hole_is_not_a_seam():
    seam = piece(line([0, 0, 0], [0.036, 0, 0]))
    flags = np.zeros(len(seam.positions_m), np.uint8)
    flags[3:15] = PointFlag.INTERPOLATED  # 23 mm of its 36 bridged a hole: 13 mm seen
    assert split_seams([replace(seam, flags=flags)], [], SplitConfig(), step_m=0.002) == []
    assert len(split_seams([seam], [], SplitConfig(), step_m=0.002)) == 1


@pytest.mark.parametrize("kind", [JointKind.LAP, JointKind.OUTSIDE_CORNER])
def test_a_seam_shorter_than_its_kinds_shortest_is_dropped(kind):
    """A lap's top plate edge, or two plates' outside corner, runs the plates' length: a 40 mm step
    is a clamp's arm on a plate, a 40 mm convex ridge a part's or a bar's edge; a 40 mm groove is
    a seam."""
    short = line([0, 0, 0], [0.04, 0, 0])
    kept = split_seams([piece(short, kind), piece(short + [0, 0.1, 0])], [], SplitConfig(), step_m=0.002)
    assert [seam.joint for seam in kept] == [JointKind.V_GROOVE]
    long_one = split_seams([piece(line([0, 0, 0], [0.06, 0, 0]), kind)], [], SplitConfig(), step_m=0.002)
    assert len(long_one) == 1
