import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from weldseam.robot.check import HOME_JOINTS_RAD
from weldseam.robot.kinematics import ROBOTS, forward
from weldseam.robot.motion import pose_matrices, pose_vectors
from weldseam.robot.sim_controller import (
    DONE,
    MOVEL,
    PATH,
    READY,
    SET_TCP,
    STOPL,
    Faults,
    SimController,
    path_from_script,
)

UR5 = ROBOTS["ur5"]
DOWN = [0.0, np.pi, 0.0]  # torch pointing down (-z)


def script(entries) -> str:
    """A control script as ur-rtde 1.6.5 uploads it for moveL(path): one movel per entry (recorded format)."""
    lines = "".join(
        f"\tsignal_async_progress({i})\n\tmovel(p[{','.join(f'{v:g}' for v in row[:6])}],a={row[7]:g},v={row[6]:g},"
        f"r={row[8]:g})\n"
        for i, row in enumerate(entries)
    )
    return f"def rtde_control():\n    def exec_move_path():\n        textmsg(\"exec_move_path\")\n{lines}    end\n" + (
        "    movel(pose, a=acceleration, v=velocity)\nend\n"
    )


class Recorder:
    def __init__(self, faults=Faults()):
        self.events, self.disconnects = [], 0
        self.sim = SimController(UR5, HOME_JOINTS_RAD, faults, self.events.append, self._disconnect)

    def _disconnect(self):
        self.disconnects += 1

    def command(self, command, doubles=(), asynchronous=False):
        values = {f"input_double_register_{i}": (float(v),) for i, v in enumerate(doubles)}
        values["input_int_register_1"] = (int(asynchronous),)
        self.sim.receive_inputs({"input_int_register_0": (command,), **values})

    def clear(self):
        self.sim.receive_inputs({"input_int_register_0": (0,)})

    def kinds(self):
        return [event["event"] for event in self.events]


def start_pose():
    return pose_vectors(forward(UR5, HOME_JOINTS_RAD))


def straight_path(count=5, step_m=0.01):
    start = start_pose()
    rows = []
    for index in range(count):
        pose = start.copy()
        pose[0] += step_m * index
        rows.append([*pose, 0.01, 0.5, 0.002 if index < count - 1 else 0.0])
    return np.array(rows)


def progress(register: int) -> tuple[bool, int]:
    """(running, progress) as ur-rtde decodes output_int_register_2."""
    return bool(register & 0x8000), register & 0x7FFF


def test_path_from_script_reads_entries_in_move_l_order():
    entries = np.array([[0.4, -0.1, 0.3, 0, 3.14159, 0, 0.01, 0.5, 0.001], [0.41, -0.1, 0.3, 0, 3.14, 0, 0.02, 0.6, 0]])
    assert np.array_equal(path_from_script(script(entries)), entries)
    assert path_from_script("def rtde_control():\nend\n").shape == (0, 9)


def test_handshake_ready_done_ready_and_set_tcp_moves_the_reported_tcp():
    robot = Recorder()
    robot.command(SET_TCP, [0, 0, 0.2, 0, 0, 0])
    assert robot.kinds() == [] and robot.sim.out_int[0] == 0, "no control script: commands are ignored"
    robot.clear()
    robot.sim.load_script(script([]))
    assert robot.sim.out_int[0] == READY and robot.sim.program_running
    flange = forward(UR5, HOME_JOINTS_RAD)
    robot.command(SET_TCP, [0, 0, 0.2, 0, 0, 0])
    assert robot.sim.out_int[0] == DONE
    assert robot.events[-1]["event"] == "set_tcp" and robot.events[-1]["pose"] == [0, 0, 0.2, 0, 0, 0]
    expected = flange[:3, 3] + 0.2 * flange[:3, 2]
    assert np.allclose(robot.sim.value("actual_TCP_pose")[:3], expected, atol=1e-12)
    robot.command(SET_TCP, [0, 0, 0.3, 0, 0, 0])
    assert len(robot.events) == 1, "a command held in the register runs once"
    robot.clear()
    assert robot.sim.out_int[0] == READY


def test_synchronous_movel_takes_distance_over_speed_and_interpolates():
    robot = Recorder()
    robot.sim.load_script(script([]))
    target = start_pose()
    target[2] -= 0.1
    target[3:] = Rotation.from_rotvec(target[3:]).__mul__(Rotation.from_rotvec([0, 0, 0.2])).as_rotvec()
    robot.command(MOVEL, [*target, 0.05, 1.0])
    assert robot.sim.out_int[0] == READY, "a blocking move is done only when it arrives"
    robot.sim.advance(1.0)  # half of 0.1 m at 0.05 m/s
    halfway = np.array(robot.sim.value("actual_TCP_pose"))
    assert halfway[2] == pytest.approx(start_pose()[2] - 0.05, abs=1e-12)
    turned = Rotation.from_rotvec(start_pose()[3:]).inv() * Rotation.from_rotvec(halfway[3:])
    assert turned.magnitude() == pytest.approx(0.1, abs=1e-9)
    robot.sim.advance(1.0 + 1e-9)
    assert robot.sim.out_int[0] == DONE
    assert np.allclose(pose_matrices(robot.sim.value("actual_TCP_pose")), pose_matrices(target), atol=1e-9)
    assert np.allclose(forward(UR5, np.array(robot.sim.value("actual_q"))), pose_matrices(target), atol=1e-9)


def test_async_path_reports_progress_per_waypoint_then_finishes():
    robot = Recorder()
    entries = straight_path(5)
    robot.sim.load_script(script(entries))
    robot.command(PATH, asynchronous=True)
    assert robot.sim.out_int[0] == DONE, "an asynchronous command is acknowledged at once"
    assert np.allclose(robot.events[-1]["entries"], entries, rtol=1e-5, atol=1e-12), "6 significant digits, as sent"
    seen = [progress(robot.sim.out_int[2])]
    for _ in range(45):
        robot.sim.advance(0.1)  # 10 mm per waypoint at 10 mm/s: one waypoint per second
        seen.append(progress(robot.sim.out_int[2]))
    assert [p for running, p in seen if running] == sorted(p for running, p in seen if running)
    assert {p for running, p in seen if running} == {0, 1, 2, 3, 4}
    assert seen[-1] == (False, 0) and np.allclose(robot.sim.value("actual_TCP_pose"), entries[-1, :6], atol=1e-9)


def test_protective_stop_at_a_waypoint_stops_the_arm_there_and_the_script():
    robot = Recorder(Faults(protective_stop_at=7))
    robot.sim.load_script(script(straight_path(5)))
    robot.command(PATH, asynchronous=True)
    robot.sim.advance(10.0)
    robot.clear()
    robot.sim.load_script(script(straight_path(5)))  # waypoints count on across paths: 5..9
    robot.command(PATH, asynchronous=True)
    robot.sim.advance(10.0)
    stop = robot.events[-1]
    assert stop["event"] == "protective_stop" and stop["waypoint"] == 7
    assert np.allclose(stop["tcp_pose"], straight_path(5)[2, :6], atol=1e-9)
    assert not robot.sim.program_running
    assert robot.sim.value("safety_status_bits") == (4,) and robot.sim.value("robot_status_bits") == (1,)
    robot.sim.unlock_protective_stop()
    assert robot.sim.value("safety_status_bits") == (1,)


def test_disconnect_fault_calls_back_once_at_its_waypoint():
    robot = Recorder(Faults(disconnect_at=1))
    robot.sim.load_script(script(straight_path(3)))
    robot.command(PATH, asynchronous=True)
    robot.sim.advance(10.0)
    assert robot.disconnects == 1 and robot.events[-1]["event"] == "disconnect" and robot.events[-1]["waypoint"] == 1
    assert robot.sim.move is None


def test_stopl_halts_where_the_tcp_is():
    robot = Recorder()
    robot.sim.load_script(script(straight_path(5)))
    robot.command(PATH, asynchronous=True)
    robot.sim.advance(1.5)
    robot.clear()
    robot.command(STOPL, [2.0], asynchronous=False)
    assert robot.events[-1]["event"] == "stopl" and robot.events[-1]["deceleration_m_s2"] == 2.0
    assert robot.events[-1]["tcp_pose"][0] == pytest.approx(start_pose()[0] + 0.015, abs=1e-6)
    assert progress(robot.sim.out_int[2])[0] is False
    before = robot.sim.value("actual_TCP_pose")
    robot.sim.advance(5.0)
    assert robot.sim.value("actual_TCP_pose") == before


def test_digital_outputs_follow_mask_and_record_the_tcp():
    robot = Recorder()
    robot.sim.receive_inputs({"standard_digital_output_mask": (0b1010,), "standard_digital_output": (0b1000,)})
    assert robot.sim.value("actual_digital_output_bits") == (0b1000,)
    assert [(e["index"], e["on"]) for e in robot.events] == [(3, True)]
    assert np.allclose(robot.events[0]["tcp_pose"], start_pose(), atol=1e-9)
    robot.sim.receive_inputs({"standard_digital_output_mask": (0b1000,), "standard_digital_output": (0,)})
    assert robot.sim.value("actual_digital_output_bits") == (0,) and robot.events[-1]["on"] is False


def test_inverse_kinematics_answers_joints_that_reach_the_pose_or_stops_the_script():
    robot = Recorder()
    robot.sim.load_script(script([]))
    target = start_pose()
    target[:3] += [0.05, -0.1, -0.1]
    robot.command(46, target)
    joints = np.array(robot.sim.out_double[:6])
    assert np.allclose(pose_matrices(target), forward(UR5, joints), atol=1e-9)
    assert np.abs(joints - HOME_JOINTS_RAD).max() < 1.0, "the solution nearest the current joints"
    robot.clear()
    robot.command(46, [2.0, 0, 0, *DOWN])
    assert robot.events[-1]["event"] == "fault" and not robot.sim.program_running
