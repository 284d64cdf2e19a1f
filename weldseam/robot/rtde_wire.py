"""RTDE framing and field types: what a UR controller and ur-rtde exchange on port 30004.

A packet is a big-endian header (uint16 size including the 3 header bytes, uint8 type) and a payload.
Types used: V protocol version, v controller version, O output setup, I input setup, S start, P pause,
U data, M text. Field types follow Universal Robots' RTDE guide.
"""

from __future__ import annotations

import re
import socket
import struct

HEADER = struct.Struct(">HB")

PROTOCOL_VERSION = ord("V")
CONTROLLER_VERSION = ord("v")
OUTPUT_SETUP = ord("O")
INPUT_SETUP = ord("I")
START = ord("S")
PAUSE = ord("P")
DATA = ord("U")
TEXT = ord("M")

STRUCT_CODES = {
    "DOUBLE": "d",
    "VECTOR3D": "ddd",
    "VECTOR6D": "dddddd",
    "VECTOR6INT32": "iiiiii",
    "VECTOR6UINT32": "IIIIII",
    "UINT64": "Q",
    "UINT32": "I",
    "INT32": "i",
    "UINT8": "B",
    "BOOL": "?",
}

_EXACT_TYPES = {
    "DOUBLE": (
        "timestamp target_speed_fraction speed_scaling speed_scaling_combined actual_momentum actual_main_voltage "
        "actual_robot_voltage actual_robot_current actual_execution_time standard_analog_input0 "
        "standard_analog_input1 standard_analog_output0 standard_analog_output1 io_current tool_analog_input0 "
        "tool_analog_input1 tool_output_current tool_temperature tcp_force_scalar payload speed_slider_fraction"
    ),
    "VECTOR3D": "actual_tool_accelerometer payload_cog elbow_position elbow_velocity",
    "VECTOR6INT32": "joint_mode",
    "UINT64": "actual_digital_input_bits actual_digital_output_bits",
    "INT32": "robot_mode safety_mode safety_status tool_output_voltage",
    "UINT32": (
        "tool_mode runtime_state robot_status_bits safety_status_bits speed_slider_mask script_control_line "
        "output_bit_registers0_to_31 output_bit_registers32_to_63 input_bit_registers0_to_31 "
        "input_bit_registers32_to_63"
    ),
    "UINT8": (
        "standard_digital_output_mask standard_digital_output configurable_digital_output_mask "
        "configurable_digital_output tool_digital_output_mask tool_digital_output standard_analog_output_mask "
        "standard_analog_output_type analog_io_types tool_analog_input_types tool_output_mode "
        "tool_digital_output0_mode tool_digital_output1_mode"
    ),
    "VECTOR6D": "payload_inertia external_force_torque ft_raw_wrench actual_current_window",
}
FIELD_TYPES = {name: kind for kind, names in _EXACT_TYPES.items() for name in names.split()}
_PATTERN_TYPES = (
    (re.compile(r"^(input|output)_int_register_\d+$"), "INT32"),
    (re.compile(r"^(input|output)_double_register_\d+$"), "DOUBLE"),
    (re.compile(r"^(input|output)_bit_register_\d+$"), "BOOL"),
    (re.compile(r"(_q|_qd|_qdd|_current|_moment|_pose|_speed|_force|_temperatures|_output|_voltage)$"), "VECTOR6D"),
)


def field_type(name: str) -> str:
    """The RTDE type of a field name ("NOT_FOUND" for names a controller does not know)."""
    if name in FIELD_TYPES:
        return FIELD_TYPES[name]
    for pattern, kind in _PATTERN_TYPES:
        if pattern.search(name):
            return kind
    return "NOT_FOUND"


def packet(kind: int, payload: bytes = b"") -> bytes:
    """One framed packet."""
    return HEADER.pack(HEADER.size + len(payload), kind) + payload


def recipe_struct(types: list[str]) -> struct.Struct:
    """The big-endian layout of one data packet's values (after its recipe id byte)."""
    return struct.Struct(">" + "".join(STRUCT_CODES[kind] for kind in types))


class PacketReader:
    """Reads framed packets from a socket; raises ConnectionError when the peer goes away."""

    def __init__(self, connection: socket.socket):
        self.connection = connection
        self.buffer = b""

    def read(self) -> tuple[int, bytes]:
        """(type, payload) of the next packet."""
        while len(self.buffer) < HEADER.size or len(self.buffer) < HEADER.unpack_from(self.buffer)[0]:
            chunk = self.connection.recv(65536)
            if not chunk:
                raise ConnectionError("peer closed the connection")
            self.buffer += chunk
        size, kind = HEADER.unpack_from(self.buffer)
        payload, self.buffer = self.buffer[HEADER.size : size], self.buffer[size:]
        return kind, payload
