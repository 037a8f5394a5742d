"""~/lowcmd's bytes read without a message object give what rclpy's own deserialisation gives."""

from __future__ import annotations

import os
import struct

os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")  # the product's serialiser (one_dds_stack.py)

from g1_mode_manager_msgs.msg import JointCommand
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

from g1_mode_manager.node.joint_command_cdr import JointCommandReader
from g1_mode_manager.protocol.motors import JOINT_NAMES

names = st.lists(st.one_of(st.sampled_from(JOINT_NAMES), st.text(max_size=9)), max_size=31)
column = st.lists(st.floats(allow_nan=False, width=64), max_size=31)


def _message(n, q, dq, tau, kp, kd, sec=0) -> JointCommand:
    msg = JointCommand(name=n, q=q, dq=dq, tau=tau, kp=kp, kd=kd)
    msg.stamp.sec = sec
    return msg


@settings(max_examples=150, deadline=None)
@given(names, column, column, column, column, column, st.integers(0, 2**31 - 1))
def test_fields_equal_the_message(n, q, dq, tau, kp, kd, sec) -> None:
    data = serialize_message(_message(n, q, dq, tau, kp, kd, sec))
    msg = deserialize_message(data, JointCommand)
    expected = (tuple(msg.name), tuple(msg.q), tuple(msg.dq), tuple(msg.tau), tuple(msg.kp), tuple(msg.kd))
    assert JointCommandReader().fields(data) == expected


def test_the_names_are_reused_only_while_they_are_the_same() -> None:
    reader = JointCommandReader()
    data = serialize_message(_message(list(JOINT_NAMES), [0.1] * 29, [], [], [1.0] * 29, [2.0] * 29))
    first = reader.fields(data)
    again = reader.fields(serialize_message(_message(list(JOINT_NAMES), [0.2] * 29, [], [], [1.0] * 29, [2.0] * 29, 7)))
    assert again[0] == first[0] and again[1] == (0.2,) * 29
    if data[:2] == b"\x00\x01":  # the plain little-endian CDR that Fast DDS writes: the names' tuple is reused
        assert again[0] is first[0]
    # a longer list that starts with the same names, and a shorter one: read anew
    longer = reader.fields(serialize_message(_message([*JOINT_NAMES, "x"], [0.0] * 30, [], [], [0.0] * 30, [0.0] * 30)))
    assert longer[0] == (*JOINT_NAMES, "x")
    shorter = reader.fields(serialize_message(_message(list(JOINT_NAMES[:2]), [0.3, 0.4], [], [], [1.0] * 2, [2.0] * 2)))
    assert shorter[0] == tuple(JOINT_NAMES[:2]) and shorter[1] == (0.3, 0.4)


def _with_padding(data: bytes, fill: int) -> bytes:
    """``data`` with the alignment padding between its names set to ``fill`` (a serialiser leaves it as it was)."""
    out = bytearray(data)
    (count,) = struct.unpack_from("<I", out, 12)
    at = 16
    for _ in range(count):
        while (at - 4) % 4:
            out[at] = fill
            at += 1
        (size,) = struct.unpack_from("<I", out, at)
        at += 4 + size
    return bytes(out)


def test_the_names_are_reused_whatever_the_padding_between_them_holds() -> None:
    data = serialize_message(_message(list(JOINT_NAMES), [0.1] * 29, [], [], [1.0] * 29, [2.0] * 29))
    assert data[:2] == b"\x00\x01"
    reader = JointCommandReader()
    first = reader.fields(_with_padding(data, 0x00))
    again = reader.fields(_with_padding(data, 0xA5))
    assert _with_padding(data, 0x00) != _with_padding(data, 0xA5), "the names have no padding: nothing was tested"
    assert again == first == reader.fields(data) == JointCommandReader().fields(_with_padding(data, 0xA5))
    assert again[0] is first[0]


def test_bytes_cut_short_are_an_error_never_a_command() -> None:
    data = serialize_message(_message(list(JOINT_NAMES), [0.5] * 29, [], [], [1.0] * 29, [2.0] * 29))
    reader = JointCommandReader()
    reader.fields(data)  # the names are remembered: the cut message takes the cached path
    for cut in (len(data) - 300, len(data) // 2, 40):  # (rclpy leaves a few spare bytes at the end)
        try:
            fields = reader.fields(data[:cut])
        except Exception:
            continue
        raise AssertionError(f"{cut} bytes of {len(data)} read as a command: {fields}")
