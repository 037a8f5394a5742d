"""rt/odommodestate and rt/lf/odommodestate: the robot's state estimate, unitree_go SportModeState_.

The G1 publishes its estimator's odometry in the Go2's message type (not unitree_hg's SportModeState_ of
rt/sportmodestate), in high-level mode only and on recent firmware. Every field is fixed-size, so one
struct reads and writes the whole CDR body: the sim packs it at 500 Hz and the node unpacks it, neither
through cyclonedds' per-field serialiser. Other encodings are deserialised by the SDK adapter
(``sdk.odom_reader.decode_odom``): this module imports no DDS, so that the core can name the fields.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Final

__all__ = ["OdomFields", "encode_odom", "rotate_into_body", "unpack_odom"]

# stamp (sec, nanosec), error_code, imu (quaternion w,x,y,z, gyroscope, accelerometer, rpy, temperature), mode,
# progress, gait_type, foot_raise_height, position[3], body_height, velocity[3], yaw_speed, range_obstacle[4],
# foot_force[4], foot_position_body[12], foot_speed_body[12], path_point[10] (7 floats each).
_BODY: Final = struct.Struct("<iII4f3f3f3fBB2xfB3xf3ff3ff4f4h12f12f70f")
_HEADER: Final = b"\x00\x01\x00\x00"  # CDR, little endian
_LITTLE_ENDIAN_ENCODINGS: Final = (0x01, 0x07)
_TAIL: Final = (0.0,) * 4 + (0,) * 4 + (0.0,) * (12 + 12 + 70)


@dataclass(frozen=True)
class OdomFields:
    """Position m and velocity m/s in the odometry frame, yaw_speed rad/s; quaternion (w, x, y, z) of the
    body in that frame; stamp s (the robot's clock)."""

    stamp_s: float
    position: tuple[float, float, float]
    velocity: tuple[float, float, float]
    yaw_speed: float
    quaternion: tuple[float, float, float, float]
    gyroscope: tuple[float, float, float]
    rpy: tuple[float, float, float]
    body_height: float


def encode_odom(f: OdomFields) -> bytes:
    """The serialised message (header included), the rest of its fields zero."""
    sec = int(f.stamp_s)
    return _HEADER + _BODY.pack(sec, int((f.stamp_s - sec) * 1e9), 0, *f.quaternion, *f.gyroscope, 0.0, 0.0, 0.0,
                                *f.rpy, 0, 0, 0.0, 0, 0.0, *f.position, f.body_height, *f.velocity, f.yaw_speed,
                                *_TAIL)


def unpack_odom(data: bytes) -> OdomFields | None:
    """The fields of a little-endian serialisation; None for any other encoding (deserialise it instead)."""
    if len(data) < 4 + _BODY.size or data[1] not in _LITTLE_ENDIAN_ENCODINGS:
        return None
    v = _BODY.unpack_from(data, 4)
    return OdomFields(stamp_s=v[0] + v[1] * 1e-9, quaternion=v[3:7], gyroscope=v[7:10], rpy=v[13:16],
                      position=v[21:24], body_height=v[24], velocity=v[25:28], yaw_speed=v[28])


def rotate_into_body(q_wxyz: tuple[float, float, float, float], v: tuple[float, float, float]) -> tuple[float, ...]:
    """``v`` (in the odometry frame) expressed in the body frame whose orientation is ``q_wxyz``."""
    w, x, y, z = q_wxyz
    n = math.sqrt(w * w + x * x + y * y + z * z) or 1.0
    w, x, y, z = w / n, -x / n, -y / n, -z / n  # the inverse rotation
    # v' = v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z)
    cx, cy, cz = y * v[2] - z * v[1], z * v[0] - x * v[2], x * v[1] - y * v[0]
    return (v[0] + 2 * (w * cx + y * cz - z * cy), v[1] + 2 * (w * cy + z * cx - x * cz),
            v[2] + 2 * (w * cz + x * cy - y * cx))
