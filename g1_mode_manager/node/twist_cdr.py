"""geometry_msgs/Twist from its serialised bytes: the three fields /cmd_vel uses, without a message object.

A Twist is six float64 after the 4-byte encapsulation header, in every plain CDR encoding (XCDR1 and
XCDR2 align them alike). Unpacking them with ``struct`` costs a small fraction of rclpy's conversion
into a Twist with two Vector3, at 100 Hz and more. Anything else (another encapsulation, a short buffer) goes through
rclpy's own deserialisation.
"""

from __future__ import annotations

import struct
from typing import Final

from geometry_msgs.msg import Twist
from rclpy.serialization import deserialize_message

_LE: Final = struct.Struct("<6d")
_BE: Final = struct.Struct(">6d")
#: Encapsulation ids of plain CDR: CDR_BE, CDR_LE, CDR2_BE, CDR2_LE (the low bit says little endian).
_PLAIN: Final = frozenset((0x0000, 0x0001, 0x0006, 0x0007))


def twist_velocity(data: bytes) -> tuple[float, float, float]:
    """(linear.x, linear.y, angular.z) of a serialised Twist."""
    if len(data) >= 4 + _LE.size:
        kind = int.from_bytes(data[:2], "big")
        if kind in _PLAIN:
            vx, vy, _vz, _wx, _wy, wz = (_LE if kind & 1 else _BE).unpack_from(data, 4)
            return vx, vy, wz
    msg = deserialize_message(data, Twist)
    return msg.linear.x, msg.linear.y, msg.angular.z
