"""What the body checks read from one serialised LowState_: IMU attitude and rates, joint speeds, motor
temperatures and the remote's bytes, decoded with ``struct`` from the fixed CDR layout.

Offsets after the 4-byte encapsulation header (checked against cyclonedds' serialisation by a test): the
IMU quaternion (w, x, y, z) and gyroscope at 16; MotorState_ i has q at 72 + 56 i, dq at 76 + 56 i and its two int16
temperatures (casing, winding: ``temperature[0]``, ``temperature[1]`` as Unitree's termination checks read
them) at 88 + 56 i; ``wireless_remote`` (40 bytes) at 2028. Other encodings are deserialised by
``protocol.lowstate_fields.decode_body_fields``: this module imports no DDS, so that the core can name the fields.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Final

from g1_mode_manager.protocol.motors import NUM_JOINTS

REMOTE_BYTES: Final = 40


@dataclass(frozen=True)
class BodyFields:
    """Motor order for the per-motor tuples; temperatures in °C, rates in rad/s."""

    quaternion: tuple[float, float, float, float]  # w, x, y, z
    gyroscope: tuple[float, float, float]
    dq: tuple[float, ...]
    casing_c: tuple[int, ...]  # temperature[0]
    winding_c: tuple[int, ...]  # temperature[1]
    remote: bytes  # wireless_remote
    #: joint positions, rad: what a controller in the node's loop reads beside the checks' fields of the same sample
    q: tuple[float, ...] = ()


_IMU: Final = struct.Struct("<7f")  # quaternion[4], gyroscope[3]
_IMU_AT: Final = 4 + 16
_DQ: Final = struct.Struct("<" + "f52x" * (NUM_JOINTS - 1) + "f")
_DQ_AT: Final = 4 + 76
_Q_AT: Final = 4 + 72  # the same stride as dq
_TEMPERATURE: Final = struct.Struct("<" + "hh52x" * (NUM_JOINTS - 1) + "hh")
_TEMPERATURE_AT: Final = 4 + 88
_REMOTE_AT: Final = 4 + 2028
_LITTLE_ENDIAN_ENCODINGS: Final = (0x01, 0x07)


def unpack_body_fields(data: bytes) -> BodyFields | None:
    """The fields of a little-endian serialisation; None for any other encoding (deserialise it instead)."""
    if data[0] != 0 or data[1] not in _LITTLE_ENDIAN_ENCODINGS or len(data) < _REMOTE_AT + REMOTE_BYTES:
        return None
    imu = _IMU.unpack_from(data, _IMU_AT)
    temperatures = _TEMPERATURE.unpack_from(data, _TEMPERATURE_AT)
    return BodyFields(quaternion=imu[0:4], gyroscope=imu[4:7], dq=_DQ.unpack_from(data, _DQ_AT),
                      casing_c=temperatures[0::2], winding_c=temperatures[1::2],
                      remote=bytes(data[_REMOTE_AT:_REMOTE_AT + REMOTE_BYTES]), q=_DQ.unpack_from(data, _Q_AT))
