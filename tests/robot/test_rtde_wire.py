import socket
import struct

import pytest

from weldseam.robot import rtde_wire as wire

# The output recipe ur-rtde 1.6.5's RTDEReceiveInterface asks an e-Series controller for (recorded).
RECEIVE_RECIPE = (
    "timestamp target_q target_qd target_qdd target_current target_moment actual_q actual_qd actual_current "
    "joint_control_output actual_TCP_pose actual_TCP_speed actual_TCP_force target_TCP_pose target_TCP_speed "
    "actual_digital_input_bits joint_temperatures actual_execution_time robot_mode joint_mode safety_mode "
    "actual_tool_accelerometer speed_scaling target_speed_fraction actual_momentum actual_main_voltage "
    "actual_robot_voltage actual_robot_current actual_joint_voltage actual_digital_output_bits runtime_state "
    "standard_analog_input0 standard_analog_input1 standard_analog_output0 standard_analog_output1 "
    "robot_status_bits safety_status_bits ft_raw_wrench payload payload_cog payload_inertia output_int_register_2"
).split()


def test_field_types_follow_the_rtde_guide():
    assert "NOT_FOUND" not in [wire.field_type(name) for name in RECEIVE_RECIPE]
    expected = {
        "timestamp": "DOUBLE", "actual_TCP_pose": "VECTOR6D", "actual_robot_current": "DOUBLE",
        "actual_current": "VECTOR6D", "joint_mode": "VECTOR6INT32", "actual_digital_output_bits": "UINT64",
        "robot_status_bits": "UINT32", "safety_mode": "INT32", "payload_cog": "VECTOR3D",
        "output_int_register_2": "INT32", "input_double_register_17": "DOUBLE", "standard_digital_output": "UINT8",
        "input_bit_register_70": "BOOL",
    }  # fmt: skip
    assert {name: wire.field_type(name) for name in expected} == expected
    assert wire.field_type("no_such_field") == "NOT_FOUND"


def test_packets_round_trip_through_a_socket_in_pieces():
    left, right = socket.socketpair()
    payload = struct.pack(">d", 125.0) + b"timestamp,actual_q,"
    data = wire.packet(wire.OUTPUT_SETUP, payload) + wire.packet(wire.START)
    assert struct.unpack(">H", data[:2])[0] == 3 + len(payload)
    for index in range(0, len(data), 5):
        left.sendall(data[index : index + 5])
    reader = wire.PacketReader(right)
    assert reader.read() == (wire.OUTPUT_SETUP, payload)
    assert reader.read() == (wire.START, b"")
    left.close()
    with pytest.raises(ConnectionError):
        reader.read()
    right.close()


def test_recipe_struct_packs_vectors_and_scalars_big_endian():
    layout = wire.recipe_struct(["VECTOR6D", "INT32", "UINT8"])
    assert layout.size == 6 * 8 + 4 + 1
    assert layout.unpack(layout.pack(*range(6), -3, 255)) == (0.0, 1.0, 2.0, 3.0, 4.0, 5.0, -3, 255)
