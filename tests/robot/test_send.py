from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from weldseam.errors import InputError, RobotFault, StageError
from weldseam.robot.moves import Shaping, motion_plan
from weldseam.robot.send import execute, path_entries, sigterm_as_interrupt
from weldseam.types import WeldPath

DOWN = np.column_stack([np.cross([1.0, 0, 0], [0, 0, -1.0]), [1.0, 0, 0], [0, 0, -1.0]])


def arc(seam_id: int) -> WeldPath:
    angles = np.linspace(0.0, np.pi / 2, 300)
    positions = 0.05 * np.column_stack([np.cos(angles), np.sin(angles), np.zeros(300)])
    return WeldPath(seam_id=seam_id, positions_m=positions, rotations=np.tile(DOWN, (300, 1, 1)))


class FakeClient:
    """Records calls; can fail (RobotFault or KeyboardInterrupt) at waypoint `fail_at` of the first path."""

    def __init__(self, fail_at: int | None = None, failure: type[BaseException] = RobotFault):
        self.calls: list[tuple] = []
        self.fail_at, self.failure = fail_at, failure

    def set_tcp(self, pose):
        self.calls.append(("tcp", tuple(pose)))

    def set_payload(self, kg, cog_m):
        self.calls.append(("payload", kg, tuple(cog_m)))

    def move_linear(self, pose, speed_m_s, acceleration_m_s2):
        self.calls.append(("movel", tuple(pose), speed_m_s))

    def move_path(self, entries, on_progress):
        self.calls.append(("path", np.array(entries)))
        for index in range(len(entries)):
            if index == self.fail_at:
                raise self.failure("protective stop")
            on_progress(index)

    def set_digital_output(self, index, on):
        self.calls.append(("do", index, on))

    def stop(self):
        self.calls.append(("stop",))

    def actual_tcp_pose(self):
        return np.zeros(6)


PLAN = motion_plan([arc(0), arc(1)], Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0), arc_output=4, standoff_m=0.01))


def test_sequence_and_arc_around_each_weld():
    client = FakeClient()
    progress = []
    execute(PLAN, client, on_progress=lambda seam, index: progress.append((seam, index)))
    kinds = [call[0] for call in client.calls]
    assert kinds == ["tcp", "do"] + ["movel", "movel", "do", "path", "do", "movel"] * 2, "the robot's payload untouched"
    assert client.calls[1] == ("do", 4, False), "the arc output is off before the first move"
    for seam_number, seam in enumerate(PLAN.seams):
        base = 2 + 6 * seam_number
        approach, first, on, path, off, retreat = client.calls[base : base + 6]
        np.testing.assert_array_equal(approach[1], seam.approach_pose)
        np.testing.assert_array_equal(first[1], seam.weld_poses[0])
        assert on == ("do", 4, True) and off == ("do", 4, False)
        np.testing.assert_array_equal(path[1], path_entries(seam, PLAN))
        np.testing.assert_array_equal(retreat[1], seam.retreat_pose)
    assert len(progress) == sum(len(seam.weld_poses) for seam in PLAN.seams)


def test_fault_stops_switches_arc_off_and_names_waypoint():
    client = FakeClient(fail_at=3)
    with pytest.raises(RobotFault, match=r"seam 0, waypoint 2 of \d+: protective stop \(arm stopped, arc off; nothing"):
        execute(PLAN, client)
    assert client.calls[-2:] == [("stop",), ("do", 4, False)]
    assert sum(call[0] == "path" for call in client.calls) == 1


class LostClient(FakeClient):
    """The connection drops at waypoint 3: the fault, then stop and the arc output fail too."""

    def stop(self):
        raise RobotFault("connection lost")

    def set_digital_output(self, index, on):
        if any(call[0] == "path" for call in self.calls):
            raise RobotFault("connection lost")
        super().set_digital_output(index, on)


def test_a_fault_that_leaves_the_arc_unconfirmed_says_so():
    with pytest.raises(RobotFault, match=r"waypoint 2 .*stopL not confirmed, ARC OUTPUT NOT CONFIRMED OFF"):
        execute(PLAN, LostClient(fail_at=3))


def test_interrupt_stops_and_switches_arc_off():
    client = FakeClient(fail_at=1, failure=KeyboardInterrupt)
    with pytest.raises(KeyboardInterrupt):
        execute(PLAN, client)
    assert client.calls[-2:] == [("stop",), ("do", 4, False)]


def test_sigterm_becomes_keyboard_interrupt_only_inside():
    previous = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt), sigterm_as_interrupt():
        os.kill(os.getpid(), signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) is previous


def test_a_payload_is_set_only_when_given_and_with_its_centre_of_gravity():
    client = FakeClient()
    setup = Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0), payload_kg=1.5, payload_cog_m=(0.0, 0.0, 0.07))
    execute(motion_plan([arc(0)], setup), client)
    assert client.calls[1] == ("payload", 1.5, (0.0, 0.0, 0.07))


@pytest.mark.parametrize("arc_output", [99, -1, 8])
def test_an_arc_output_that_is_no_standard_output_is_refused_before_any_call(arc_output):
    client = FakeClient()
    plan = motion_plan([arc(0)], Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0), arc_output=arc_output))
    with pytest.raises(InputError, match=rf"arc output {arc_output}: not a standard digital output \(0 to 7\)"):
        execute(plan, client)
    assert client.calls == []


def test_half_a_payload_is_refused_before_any_call():
    client = FakeClient()
    with pytest.raises(InputError, match="centre of gravity"):
        execute(motion_plan([arc(0)], Shaping(base_pose=(0.4, 0, 0.1, 0, 0, 0), payload_kg=1.0)), client)
    assert client.calls == []


class BuggyClient(FakeClient):
    """An exception no one expected (a bug, here or in ur-rtde) in the middle of the first weld."""

    def move_path(self, entries, on_progress):
        self.calls.append(("path", np.array(entries)))
        on_progress(0)
        on_progress(1)
        raise IndexError("bitset::test: __position (which is 99) >= _Nb (which is 64)")


def test_an_unexpected_exception_stops_the_arm_switches_the_arc_off_and_says_where():
    client = BuggyClient()
    expected = r"^send: seam 0, waypoint 1 of \d+: unexpected IndexError: .*\(arm stopped, arc off"
    with pytest.raises(StageError, match=expected):
        execute(PLAN, client)
    assert client.calls[-2:] == [("stop",), ("do", 4, False)]


def test_a_failing_progress_callback_stops_the_arm_and_switches_the_arc_off():
    def broken(seam, waypoint):
        raise ValueError("progress display broke")

    client = FakeClient()
    expected = r"^send: seam 0, waypoint 0 of \d+: unexpected ValueError: progress display broke \(arm stopped, arc off"
    with pytest.raises(StageError, match=expected):
        execute(PLAN, client, on_progress=broken)
    assert client.calls[-2:] == [("stop",), ("do", 4, False)]


def test_an_interrupt_says_which_seam_and_waypoint_and_that_the_arc_is_off():
    client = FakeClient(fail_at=5, failure=KeyboardInterrupt)
    with pytest.raises(KeyboardInterrupt) as interrupt:
        execute(PLAN, client)
    count = len(PLAN.seams[0].weld_poses)
    assert str(interrupt.value) == f"at seam 0, waypoint 4 of {count}: arm stopped, arc off"


class ImpatientOperatorClient(FakeClient):
    """Ctrl-C again while the arm is being stopped after the first one."""

    def stop(self):
        os.kill(os.getpid(), signal.SIGINT)
        super().stop()


def test_a_second_ctrl_c_during_the_stop_cannot_leave_the_arc_on():
    client = ImpatientOperatorClient(fail_at=2, failure=KeyboardInterrupt)
    with pytest.raises(KeyboardInterrupt, match="arm stopped, arc off"):
        execute(PLAN, client)
    assert client.calls[-2:] == [("stop",), ("do", 4, False)]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
