"""RobotSim's network side, spoken to over raw sockets (no ur-rtde): latency, START, the dashboard."""

from __future__ import annotations

import socket
import struct
import time

from weldseam.robot import rtde_wire as wire
from weldseam.robot.sim import DASHBOARD_PORT, RTDE_PORT
from weldseam.robot.sim_controller import Faults

RUNNING_SCRIPT = "def rtde_control():\n  sync()\nend\n"


def test_latency_delays_each_packet_from_its_arrival_not_after_the_packet_before(robot_sim):
    """A slow network delays five packets sent together by 0.2 s each, not by 0.2, 0.4, ... 1.0 s."""
    sim = robot_sim(faults=Faults(latency_s=0.2))
    with socket.create_connection((sim.host, RTDE_PORT), timeout=5) as connection:
        reader = wire.PacketReader(connection)
        sent_s = time.monotonic()
        connection.sendall(wire.packet(wire.PROTOCOL_VERSION, b"\x00\x02") * 5)
        answers = [reader.read() for _ in range(5)]
        elapsed_s = time.monotonic() - sent_s
    assert answers == [(wire.PROTOCOL_VERSION, b"\x01")] * 5
    assert 0.2 <= elapsed_s < 0.35, elapsed_s


def test_the_start_reply_comes_before_the_first_data_packet(robot_sim):
    sim = robot_sim()
    with socket.create_connection((sim.host, RTDE_PORT), timeout=5) as connection:
        reader = wire.PacketReader(connection)
        connection.sendall(wire.packet(wire.OUTPUT_SETUP, struct.pack(">d", 500.0) + b"timestamp,runtime_state"))
        assert reader.read()[0] == wire.OUTPUT_SETUP
        connection.sendall(wire.packet(wire.START))
        assert reader.read() == (wire.START, b"\x01")
        assert reader.read()[0] == wire.DATA


def test_a_dashboard_stop_ends_the_running_program_and_answers_as_ur_rtde_expects(robot_sim):
    """ur-rtde stops a control script it finds running through the dashboard, and raises unless told "Stopped"."""
    sim = robot_sim()
    sim.controller.load_script(RUNNING_SCRIPT)
    with socket.create_connection((sim.host, DASHBOARD_PORT), timeout=5) as connection:
        lines = connection.makefile("rb")
        assert lines.readline().startswith(b"Connected: Universal Robots Dashboard Server")
        connection.sendall(b"stop\n")
        assert lines.readline() == b"Stopped\n"
    assert not sim.controller.program_running
    assert [event["event"] for event in sim.events] == ["program_stopped"]
