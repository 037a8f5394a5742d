"""CRC-32 of unitree_hg LowCmd_ and LowState_, as the robot checks it, in a fraction of the SDK's time.

The robot ignores a LowCmd_ whose ``crc`` is wrong. The checksum is CRC-32 (poly 0x04C11DB7, init
0xFFFFFFFF, no reflection, no final xor) over the message packed as its C struct (little-endian,
4-byte aligned), taken as 32-bit words, all but the last (the ``crc`` field itself). The SDK's
``CRC().Crc`` builds a Python list of every word first, slow at 500 frames a second; here one precompiled
``struct.Struct`` packs the fields straight into bytes and the SDK's C ``crc32_core`` (or, where that
library is missing, a byte-table CRC) runs over them.
"""

from __future__ import annotations

import ctypes
import platform
import struct
from operator import attrgetter
from pathlib import Path
from typing import Final

from g1_mode_manager.protocol.idl import LowCmd_, LowState_

POLYNOMIAL: Final = 0x04C11DB7
INITIAL: Final = 0xFFFFFFFF

# Layouts of the C structs without the trailing crc word (see unitree_sdk2py/utils/crc.py).
_LOWCMD: Final = struct.Struct("<2B2x" + "B3x5fI" * 35 + "4I")  # 1000 bytes = 250 words
_LOWSTATE: Final = struct.Struct("<2I2B2xI" + "13fh2x" + "B3x4f2hf7I" * 35 + "40B4I")  # 2088 bytes = 522 words

_MOTOR_CMD_FIELDS = attrgetter("mode", "q", "dq", "tau", "kp", "kd", "reserve")


def _byte_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ POLYNOMIAL if crc & 0x80000000 else crc << 1) & 0xFFFFFFFF
        table.append(crc)
    return tuple(table)


_TABLE: Final = _byte_table()


def crc32_words_py(data: bytes) -> int:
    """CRC over little-endian 32-bit words, each fed most significant byte first (pure Python)."""
    crc = INITIAL
    table = _TABLE
    for i in range(0, len(data) - len(data) % 4, 4):
        for byte in (data[i + 3], data[i + 2], data[i + 1], data[i]):
            crc = ((crc << 8) & 0xFFFFFFFF) ^ table[(crc >> 24) ^ byte]
    return crc


def _load_sdk_crc() -> ctypes.CDLL | None:
    """The SDK's compiled crc32_core for this machine, or None."""
    names = {"x86_64": "crc_amd64.so", "aarch64": "crc_aarch64.so"}
    name = names.get(platform.machine())
    if platform.system() != "Linux" or name is None:
        return None
    try:
        import unitree_sdk2py.utils as sdk_utils

        lib = ctypes.CDLL(str(Path(sdk_utils.__file__).parent / "lib" / name))
    except (ImportError, OSError):
        return None
    lib.crc32_core.argtypes = (ctypes.c_void_p, ctypes.c_uint32)
    lib.crc32_core.restype = ctypes.c_uint32
    return lib


_SDK_LIB = _load_sdk_crc()


def crc32_words(data: bytes) -> int:
    """CRC-32 of the robot over ``data`` taken as little-endian 32-bit words (len a multiple of 4)."""
    if _SDK_LIB is None:
        return crc32_words_py(data)
    return int(_SDK_LIB.crc32_core(data, len(data) // 4))  # bytes pass as a read-only pointer


def pack_lowcmd(msg: LowCmd_) -> bytes:
    """LowCmd_ packed as its C struct, without the crc word."""
    values: list = [msg.mode_pr, msg.mode_machine]
    extend = values.extend
    for motor in msg.motor_cmd:
        extend(_MOTOR_CMD_FIELDS(motor))
    extend(msg.reserve)
    return _LOWCMD.pack(*values)


def pack_lowstate(msg: LowState_) -> bytes:
    """LowState_ packed as its C struct, without the crc word."""
    imu = msg.imu_state
    values: list = [*msg.version, msg.mode_pr, msg.mode_machine, msg.tick,
                    *imu.quaternion, *imu.gyroscope, *imu.accelerometer, *imu.rpy, imu.temperature]  # fmt: skip
    extend = values.extend
    for m in msg.motor_state:
        t, s, r = m.temperature, m.sensor, m.reserve
        extend((m.mode, m.q, m.dq, m.ddq, m.tau_est, t[0], t[1], m.vol, s[0], s[1], m.motorstate,
                r[0], r[1], r[2], r[3]))  # fmt: skip
    extend(msg.wireless_remote)
    extend(msg.reserve)
    return _LOWSTATE.pack(*values)


def lowcmd_crc(msg: LowCmd_) -> int:
    """The ``crc`` the robot expects in this unitree_hg LowCmd_ (its own crc field is ignored)."""
    return crc32_words(pack_lowcmd(msg))


def lowstate_crc(msg: LowState_) -> int:
    """The ``crc`` of a unitree_hg LowState_ (its own crc field is ignored)."""
    return crc32_words(pack_lowstate(msg))
