"""rt/lowstate frames packed straight from arrays: CDR bytes and CRC without cyclonedds' serialiser.

Serialising a unitree_hg LowState_ with cyclonedds-python and computing the SDK's CRC over it are too
slow for 500 Hz of sim time at several times real time. Every field of LowState_ is a
fixed-size primitive, so its CDR body is a fixed layout: we keep one template buffer, write q, dq,
tau_est, motor mode, temperatures and voltage, IMU, the remote's bytes, tick and crc into it through strided
numpy views,
and hand the bytes to the DataWriter through a LowState_ whose ``serialize`` returns them. A self-check at
start-up compares the result with cyclonedds' own deserialiser and the SDK's CRC.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from g1_mode_manager.protocol.crc import crc32_of_array, lowstate_crc
from g1_mode_manager.protocol.idl import IMUState_, LowState_, MotorState_
from g1_mode_manager.protocol.motors import MODE_MACHINE_G1_29DOF, NUM_JOINTS, NUM_MOTOR_SLOTS
from g1_mode_manager.protocol.remote import REMOTE_SIZE

_HEADER: Final = 4  # CDR encapsulation header
# Offsets in the CDR body (see unitree_hg LowState_.idl; all fields at most 4-byte aligned).
_MODE_MACHINE: Final = 9
_TICK: Final = 12
_IMU: Final = 16  # quaternion[4] gyroscope[3] accelerometer[3] rpy[3] float32, then int16 temperature
_MOTOR_Q0: Final = 72  # motor 0 q; MotorState_ is 56 bytes from one mode byte to the next
_MOTOR_STRIDE: Final = 56
_MOTOR_TEMPERATURE0: Final = _MOTOR_Q0 + 16  # int16[2] after q, dq, ddq, tau_est
_MOTOR_VOL0: Final = _MOTOR_Q0 + 20  # float32 after the temperatures
_MOTOR_MODE0: Final = 70  # motor 0's mode right after the IMU's int16 temperature ...
_MOTOR_MODE1: Final = _MOTOR_Q0 + _MOTOR_STRIDE - 4  # ... every other one 4 bytes before its q (3 bytes padding)
_WIRELESS_REMOTE: Final = 2028  # uint8[40] after the 35 motors, then reserve[4] and crc
_CRC: Final = 2084
_BODY_SIZE: Final = 2088
# In the C struct the CRC covers, the IMU state is padded to 72 bytes, so motor 0's mode sits at 72
# (CDR: 70) and every field from motor 0's q on lies 4 bytes later than in CDR.
_C_IMU_END: Final = 70
_CDR_MODE0: Final = 70


def _view(buf: np.ndarray, offset: int, dtype: str, count: int, stride: int) -> np.ndarray:
    return np.ndarray((count,), dtype=dtype, buffer=buf, offset=offset, strides=(stride,))


class LowStatePacker:
    """Fills one LowState_ frame (mode_machine 5) and returns the message to write.

    Not thread-safe: one packer per publishing thread.
    """

    def __init__(self, *, mode_machine: int = MODE_MACHINE_G1_29DOF) -> None:
        # XCDR1: what writers with default QoS ask for (use_version_2 None or False) for this final struct.
        raw = default_lowstate(mode_machine).serialize(use_version_2=False)
        if len(raw) != _HEADER + _BODY_SIZE:
            raise RuntimeError(f"unexpected LowState_ CDR size {len(raw)}")
        self._buf = np.frombuffer(bytearray(raw), dtype=np.uint8)
        body = _HEADER
        self._tick = _view(self._buf, body + _TICK, "<u4", 1, 4)
        self._imu = _view(self._buf, body + _IMU, "<f4", 13, 4)
        self._q = _view(self._buf, body + _MOTOR_Q0, "<f4", NUM_JOINTS, _MOTOR_STRIDE)
        self._dq = _view(self._buf, body + _MOTOR_Q0 + 4, "<f4", NUM_JOINTS, _MOTOR_STRIDE)
        self._tau = _view(self._buf, body + _MOTOR_Q0 + 12, "<f4", NUM_JOINTS, _MOTOR_STRIDE)
        self._temperature = np.ndarray((NUM_JOINTS, 2), dtype="<i2", buffer=self._buf,
                                       offset=body + _MOTOR_TEMPERATURE0, strides=(_MOTOR_STRIDE, 2))
        self._remote = _view(self._buf, body + _WIRELESS_REMOTE, "u1", REMOTE_SIZE, 1)
        self._mode0 = _view(self._buf, body + _MOTOR_MODE0, "u1", 1, 1)
        self._mode_rest = _view(self._buf, body + _MOTOR_MODE1, "u1", NUM_JOINTS - 1, _MOTOR_STRIDE)
        self._vol = _view(self._buf, body + _MOTOR_VOL0, "<f4", NUM_JOINTS, _MOTOR_STRIDE)
        self._last_temperature: np.ndarray | None = None
        self._last_remote: bytes | None = None
        self._last_mode = np.zeros(NUM_JOINTS, dtype=np.uint8)
        self._last_mode_given: np.ndarray | None = None
        self._last_vol = 0.0
        self._crc = _view(self._buf, body + _CRC, "<u4", 1, 4)
        self._c_struct = np.zeros(_BODY_SIZE, dtype=np.uint8)  # C layout without the crc word
        self._msg = default_lowstate(mode_machine)
        # The DataWriter asks the sample to serialise itself: hand it the packed bytes.
        self._msg.serialize = self._serialize  # type: ignore[method-assign]

    def pack(self, q: np.ndarray, dq: np.ndarray, tau_est: np.ndarray, quaternion_wxyz: np.ndarray,
             gyroscope: np.ndarray, accelerometer: np.ndarray, rpy: np.ndarray, tick: int,
             temperature: np.ndarray | None = None, remote: bytes | None = None,
             motor_mode: np.ndarray | None = None, vol: float | None = None) -> LowState_:
        """Write one frame; returns a LowState_ to pass to the writer (its fields are NOT updated).

        ``temperature`` (29 x [casing, winding], int16 deg C), ``remote`` (40 bytes of wireless_remote),
        ``motor_mode`` (29 x uint8) and ``vol`` (every motor's supply voltage, V) change far less often than
        the frames: they are copied only when a different object or value comes in, and otherwise stay as
        last given (zero at first). Motor slots 29..34 (no motor on the 29-dof G1) stay all zero.
        """
        if temperature is not None and temperature is not self._last_temperature:
            self._temperature[:] = temperature
            self._last_temperature = temperature
        if remote is not None and remote is not self._last_remote:
            self._remote[:] = np.frombuffer(remote, dtype=np.uint8)
            self._last_remote = remote
        if motor_mode is not None and motor_mode is not self._last_mode_given:
            self._last_mode_given = motor_mode  # a robot hands the same array while nothing changes
            if not np.array_equal(motor_mode, self._last_mode):
                self._mode0[0] = motor_mode[0]
                self._mode_rest[:] = motor_mode[1:]
                self._last_mode = np.array(motor_mode, dtype=np.uint8)
        if vol is not None and vol != self._last_vol:
            self._vol[:] = vol
            self._last_vol = vol
        self._q[:] = q
        self._dq[:] = dq
        self._tau[:] = tau_est
        imu = self._imu
        imu[0:4] = quaternion_wxyz
        imu[4:7] = gyroscope
        imu[7:10] = accelerometer
        imu[10:13] = rpy
        self._tick[0] = tick & 0xFFFFFFFF
        self._crc[0] = self._compute_crc()
        return self._msg

    def _serialize(self, buffer: object = None, endianness: object = None, use_version_2: bool | None = None) -> bytes:
        if use_version_2:
            raise RuntimeError("LowStatePacker packs XCDR1; the writer asks for XCDR2")
        return self._buf.tobytes()

    @property
    def mode_machine(self) -> int:
        return int(self._buf[_HEADER + _MODE_MACHINE])

    def frame_bytes(self) -> bytes:
        """The last packed frame as CDR (with encapsulation header)."""
        return self._buf.tobytes()

    def _compute_crc(self) -> int:
        body = self._buf[_HEADER:]
        c = self._c_struct
        c[:_C_IMU_END] = body[:_C_IMU_END]
        c[72] = body[_CDR_MODE0]
        c[76:] = body[72:_CRC]
        return crc32_of_array(c, c.size // 4)  # zlib over the bit-reversed words: a few us


def default_lowstate(mode_machine: int) -> LowState_:
    """A LowState_ at rest (upright attitude, every other field zero): the packer's template, and what
    bench.bridge_speed serialises the SDK's way to compare."""
    imu = IMUState_(quaternion=[1.0, 0.0, 0.0, 0.0], gyroscope=[0.0] * 3, accelerometer=[0.0] * 3,
                    rpy=[0.0] * 3, temperature=0)
    motors = [
        MotorState_(mode=0, q=0.0, dq=0.0, ddq=0.0, tau_est=0.0, temperature=[0, 0], vol=0.0, sensor=[0, 0],
                    motorstate=0, reserve=[0] * 4)
        for _ in range(NUM_MOTOR_SLOTS)
    ]
    return LowState_(version=[0, 0], mode_pr=0, mode_machine=mode_machine, tick=0, imu_state=imu,
                     motor_state=motors, wireless_remote=[0] * 40, reserve=[0] * 4, crc=0)


def self_check(packer: LowStatePacker) -> None:
    """Pack a frame of known values and check cyclonedds decodes it and the SDK's CRC agrees."""
    rng = np.random.default_rng(7)
    q, dq, tau = (rng.uniform(-2, 2, NUM_JOINTS).astype(np.float32) for _ in range(3))
    quat, gyro, acc, rpy = (rng.uniform(-1, 1, n).astype(np.float32) for n in (4, 3, 3, 3))
    temperature = rng.integers(-40, 200, (NUM_JOINTS, 2)).astype(np.int16)
    remote = rng.integers(0, 256, REMOTE_SIZE, dtype=np.uint8).tobytes()
    mode = rng.integers(1, 256, NUM_JOINTS).astype(np.uint8)
    packer.pack(q, dq, tau, quat, gyro, acc, rpy, 123456, temperature, remote, mode, 53.25)
    decoded = LowState_.deserialize(packer.frame_bytes())
    motors = decoded.motor_state
    got_mode = np.array([m.mode for m in motors[:NUM_JOINTS]], dtype=np.uint8)
    got_vol = np.array([m.vol for m in motors[:NUM_JOINTS]], dtype=np.float32)
    spare_slots_zero = all(m.mode == 0 and m.vol == 0.0 for m in motors[NUM_JOINTS:])
    got_temperature = np.array([m.temperature for m in decoded.motor_state[:NUM_JOINTS]], dtype=np.int16)
    got_q = np.array([m.q for m in decoded.motor_state[:NUM_JOINTS]], dtype=np.float32)
    got_dq = np.array([m.dq for m in decoded.motor_state[:NUM_JOINTS]], dtype=np.float32)
    got_tau = np.array([m.tau_est for m in decoded.motor_state[:NUM_JOINTS]], dtype=np.float32)
    imu = decoded.imu_state
    ok = (
        np.array_equal(got_q, q) and np.array_equal(got_dq, dq) and np.array_equal(got_tau, tau)
        and np.array_equal(np.array(imu.quaternion, dtype=np.float32), quat)
        and np.array_equal(np.array(imu.rpy, dtype=np.float32), rpy)
        and np.array_equal(got_temperature, temperature) and bytes(decoded.wireless_remote) == remote
        and np.array_equal(got_mode, mode) and bool(np.all(got_vol == np.float32(53.25))) and spare_slots_zero
        and decoded.tick == 123456 and decoded.mode_machine == packer.mode_machine
        and decoded.crc == lowstate_crc(decoded)
    )
    if not ok:
        raise RuntimeError("LowState_ fast packing disagrees with cyclonedds/CRC: layout changed?")
    packer.pack(q, dq, tau, quat, gyro, acc, rpy, 0, np.zeros((NUM_JOINTS, 2), dtype=np.int16), bytes(REMOTE_SIZE),
                np.zeros(NUM_JOINTS, dtype=np.uint8), 0.0)
