"""CRC-32 of unitree_hg LowCmd_ and LowState_, as the robot checks it, in a fraction of the SDK's time.

The robot ignores a LowCmd_ whose ``crc`` is wrong. The checksum is CRC-32 (poly 0x04C11DB7, init
0xFFFFFFFF, no reflection, no final xor) over the message packed as its C struct (little-endian,
4-byte aligned), taken as 32-bit words, all but the last (the ``crc`` field itself). The SDK's
``CRC().Crc`` builds a Python list of every word first, slow at 500 frames a second, and its compiled
``crc32_core`` loops bit by bit; here the words are byte-swapped by numpy and zlib does the rest (see
``_crc_of_swapped``). ``crc32_words_py`` is the plain byte-table definition the tests compare with.
"""

from __future__ import annotations

import struct
import zlib
from operator import attrgetter
from typing import Any, Final

import numpy as np

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


#: Each byte with its bits in reverse order.
_REVERSED_BITS: Final = bytes(int(f"{b:08b}"[::-1], 2) for b in range(256))


def _crc_of_swapped(swapped: bytes) -> int:
    """The robot's CRC of words given with their bytes already most significant first.

    This CRC is zlib's CRC-32 without reflection: fed the same bytes with their bits reversed, zlib's
    (reflected) register ends as the bit-reversed register of this one, and zlib's final xor is undone.
    zlib and ``bytes.translate`` run in C over the whole buffer: a few us per LowCmd_ instead of a
    loop per word.
    """
    reflected = zlib.crc32(swapped.translate(_REVERSED_BITS)) ^ 0xFFFFFFFF
    return int.from_bytes(reflected.to_bytes(4, "little").translate(_REVERSED_BITS), "big")


def crc32_words(data: bytes) -> int:
    """CRC-32 of the robot over ``data`` taken as little-endian 32-bit words (len a multiple of 4)."""
    words = np.frombuffer(data, dtype="<u4", count=len(data) // 4)
    return _crc_of_swapped(words.byteswap().tobytes())


def crc32_of_array(array: Any, words: int) -> int:
    """The same CRC over the first ``words`` 32-bit words of a C-contiguous numpy array (no copy of its own)."""
    return _crc_of_swapped(array.view("<u4").reshape(-1)[:words].byteswap().tobytes())


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
                    *imu.quaternion, *imu.gyroscope, *imu.accelerometer, *imu.rpy, imu.temperature]
    extend = values.extend
    for m in msg.motor_state:
        t, s, r = m.temperature, m.sensor, m.reserve
        extend((m.mode, m.q, m.dq, m.ddq, m.tau_est, t[0], t[1], m.vol, s[0], s[1], m.motorstate,
                r[0], r[1], r[2], r[3]))
    extend(msg.wireless_remote)
    extend(msg.reserve)
    return _LOWSTATE.pack(*values)


def lowcmd_crc(msg: LowCmd_) -> int:
    """The ``crc`` the robot expects in this unitree_hg LowCmd_ (its own crc field is ignored)."""
    return crc32_words(pack_lowcmd(msg))


def lowstate_crc(msg: LowState_) -> int:
    """The ``crc`` of a unitree_hg LowState_ (its own crc field is ignored)."""
    return crc32_words(pack_lowstate(msg))
