"""/cmd_vel taken as bytes: the decoded velocity equals rclpy's own deserialisation, whatever the values."""

from __future__ import annotations

import math
import struct

from geometry_msgs.msg import Twist
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message

from g1_mode_manager.node.twist_cdr import twist_velocity

f64 = st.floats(allow_nan=True, allow_infinity=True)


def same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


@settings(max_examples=200, deadline=None)
@given(st.lists(f64, min_size=6, max_size=6))
def test_decoded_velocity_equals_rclpys_deserialisation(values: list[float]) -> None:
    msg = Twist()
    msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.x, msg.angular.y, msg.angular.z = values
    got = twist_velocity(serialize_message(msg))
    assert all(same(g, e) for g, e in zip(got, (values[0], values[1], values[5]), strict=True))


def test_big_endian_decodes_and_the_options_field_is_ignored() -> None:
    values = (0.5, -0.25, 1.0, 2.0, 3.0, -0.75)
    big = b"\x00\x00\x00\x00" + struct.pack(">6d", *values)
    assert twist_velocity(big) == (0.5, -0.25, -0.75)
    msg = Twist()
    msg.linear.x, msg.angular.z = 0.3, 0.2
    data = serialize_message(msg)
    assert twist_velocity(data[:2] + b"\x00\x00" + data[4:]) == (0.3, 0.0, 0.2)  # options field ignored
