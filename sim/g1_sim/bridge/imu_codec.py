"""rt/secondary_imu frames packed with one struct: unitree_hg IMUState_ as the DataWriter would serialise it.

IMUState_ is 13 float32 and an int16, all fixed-size, so its CDR body is a fixed layout; packing it with a
precompiled struct costs a few microseconds where cyclonedds' per-field serialiser costs far more, at 500
frames a second. A self-check at start-up compares the bytes with cyclonedds' own serialisation.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Final

from g1_mode_manager.protocol.idl import IMUState_

_HEADER: Final = b"\x00\x01\x00\x00"  # CDR (XCDR1), little endian
# quaternion[4] (w, x, y, z), gyroscope[3], accelerometer[3], rpy[3], temperature; then the 2 bytes the
# writer pads every sample with (to a multiple of 4).
_BODY: Final = struct.Struct("<4f3f3f3fh2x")


def encode_imu(quaternion: Sequence[float], gyroscope: Sequence[float], accelerometer: Sequence[float],
               rpy: Sequence[float], temperature: int = 0) -> bytes:
    """The serialised IMUState_ (encapsulation header included)."""
    return _HEADER + _BODY.pack(*quaternion, *gyroscope, *accelerometer, *rpy, temperature)


def self_check() -> None:
    """Encode known values and check cyclonedds writes the same bytes and reads them back."""
    q, g, a, r = [0.5, -0.5, 0.25, 0.125], [1.0, -2.0, 0.5], [0.25, 0.0, 9.75], [0.1875, -0.375, 3.0]
    ours = encode_imu(q, g, a, r, -7)
    theirs = IMUState_(quaternion=q, gyroscope=g, accelerometer=a, rpy=r, temperature=-7).serialize(use_version_2=False)
    theirs = theirs.ljust((len(theirs) + 3) & ~3, b"\0")  # as DataWriter.write pads it
    decoded = IMUState_.deserialize(ours)
    if ours != theirs or list(decoded.rpy) != r or decoded.temperature != -7:
        raise RuntimeError("IMUState_ fast packing disagrees with cyclonedds: layout changed?")
