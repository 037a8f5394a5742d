"""Joint states and IMU of one serialised rt/lowstate, decoded only when someone publishes them; and the
body checks' fields (protocol.body_fields) of one, in any encoding.

rt/lowstate arrives at 500 Hz; the reader keeps the raw bytes of the latest sample, and the node
decodes them at its own (lower) publishing rate. A struct path reads the fixed CDR layout;
other encodings fall back to the full, much slower deserialisation.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Final

from g1_mode_manager.protocol.body_fields import BodyFields, unpack_body_fields
from g1_mode_manager.protocol.idl import LowState_
from g1_mode_manager.protocol.motors import NUM_JOINTS


@dataclass(frozen=True)
class LowStateFields:
    """Motor order; IMU quaternion is (w, x, y, z) as Unitree sends it, gyro rad/s, accelerometer m/s^2."""

    q: tuple[float, ...]
    dq: tuple[float, ...]
    tau: tuple[float, ...]  # tau_est, N m
    quaternion: tuple[float, float, float, float]
    gyroscope: tuple[float, float, float]
    accelerometer: tuple[float, float, float]


# CDR offsets after the 4-byte encapsulation header: IMUState_ follows version[2], mode_pr, mode_machine and
# tick at 16; MotorState_ (56 bytes: mode, q, dq, ddq, tau_est, temperature[2], vol, sensor[2], motorstate,
# reserve[4]) starts at 70, so q of motor i is at 72 + 56 i (as in state_readers.decode_lowstate).
_IMU: Final = struct.Struct("<10f")  # quaternion[4], gyroscope[3], accelerometer[3]
_IMU_AT: Final = 4 + 16
_MOTORS: Final = struct.Struct("<" + "ff4xf40x" * (NUM_JOINTS - 1) + "ff4xf")  # q, dq, (ddq), tau_est
_MOTORS_AT: Final = 4 + 72
_LITTLE_ENDIAN_ENCODINGS: Final = (0x01, 0x07)


def decode_fields(data: bytes) -> LowStateFields:
    """Decode the 29 joints' q, dq, tau_est and the IMU of a serialised LowState_."""
    if data[0] == 0 and data[1] in _LITTLE_ENDIAN_ENCODINGS and len(data) >= _MOTORS_AT + _MOTORS.size:
        imu = _IMU.unpack_from(data, _IMU_AT)
        m = _MOTORS.unpack_from(data, _MOTORS_AT)
        return LowStateFields(q=m[0::3], dq=m[1::3], tau=m[2::3], quaternion=imu[0:4], gyroscope=imu[4:7],
                              accelerometer=imu[7:10])
    return decode_fields_slowly(data)


def decode_fields_slowly(data: bytes) -> LowStateFields:
    """The same by full deserialisation: any encoding cyclonedds reads."""
    msg = LowState_.deserialize(data)
    motors = msg.motor_state[:NUM_JOINTS]
    imu_state = msg.imu_state
    return LowStateFields(
        q=tuple(float(x.q) for x in motors),
        dq=tuple(float(x.dq) for x in motors),
        tau=tuple(float(x.tau_est) for x in motors),
        quaternion=tuple(float(v) for v in imu_state.quaternion),  # type: ignore[arg-type]
        gyroscope=tuple(float(v) for v in imu_state.gyroscope),  # type: ignore[arg-type]
        accelerometer=tuple(float(v) for v in imu_state.accelerometer),  # type: ignore[arg-type]
    )


def decode_body_fields(data: bytes) -> BodyFields:
    """By the struct layout (protocol.body_fields), or by full deserialisation for other encodings."""
    fields = unpack_body_fields(data)
    return decode_body_fields_slowly(data) if fields is None else fields


def decode_body_fields_slowly(data: bytes) -> BodyFields:
    """The same by full deserialisation: any encoding cyclonedds reads."""
    msg = LowState_.deserialize(data)
    motors = msg.motor_state[:NUM_JOINTS]
    casing, winding = zip(*((int(m.temperature[0]), int(m.temperature[1])) for m in motors), strict=True)
    imu = msg.imu_state
    return BodyFields(tuple(map(float, imu.quaternion)), tuple(map(float, imu.gyroscope)),  # type: ignore[arg-type]
                      tuple(float(m.dq) for m in motors), casing, winding,
                      bytes(int(b) & 0xFF for b in msg.wireless_remote), tuple(float(m.q) for m in motors))
