"""The operator's remote as the G1 reports it: the 40 bytes of LowState_ ``wireless_remote``.

The robot copies its wireless remote's raw frame into every rt/lowstate; a program that watches the
operator (a held key combination, the sticks) decodes it from there. The node decodes with this module and
the sim encodes with it, so both read the same layout.

Layout, little-endian, checked against Unitree's own code:

* unitree_sdk2 ``example/g1/low_level/gamepad.hpp``: ``REMOTE_DATA_RX`` is a union of ``uint8_t buff[40]``
  and ``xRockerBtnDataStruct { uint8_t head[2]; xKeySwitchUnion btn; float lx, rx, ry, L2, ly;
  uint8_t idle[16]; }``, where ``xKeySwitchUnion`` is a ``uint16_t`` whose bit-field runs R1, L1, start,
  select, R2, L2, F1, F2, A, B, X, Y, up, right, down, left from bit 0 (the same header ships as
  ``unitree_joystick.h`` with Unitree's legged SDKs).
* unitree_rl_gym ``deploy/deploy_real/common/remote_controller.py``: ``KeyMap`` R1 = 0 ... left = 15, keys
  ``struct.unpack("H", data[2:4])``, lx ``data[4:8]``, rx ``[8:12]``, ry ``[12:16]``, ly ``[20:24]``.
* unitree_mujoco ``simulate_python/unitree_sdk2py_bridge.py`` packs a gamepad into the same bytes
  (byte 2 = R1..L2 in bits 0..5, byte 3 = A, B, X, Y, up, right, down, left in bits 0..7).

So: bytes 0-1 a header (left 0 here), 2-3 the key field, 4-24 five float32 (lx, rx, ry, L2 analog, ly),
24-40 idle.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Final

#: Size of LowState_.wireless_remote.
REMOTE_SIZE: Final = 40
#: Key names in bit order: KEY_NAMES[i] is bit i of the 16-bit key field (Unitree's names and spelling).
KEY_NAMES: Final = ("R1", "L1", "start", "select", "R2", "L2", "F1", "F2",
                    "A", "B", "X", "Y", "up", "right", "down", "left")
KEY_BIT: Final = {name: bit for bit, name in enumerate(KEY_NAMES)}

_KEYS_AT: Final = 2
_AXES: Final = struct.Struct("<5f")  # lx, rx, ry, L2 analog, ly
_AXES_AT: Final = 4
_KEYS: Final = struct.Struct("<H")


class UnknownKeyError(ValueError):
    """A key name that is not on the remote (see KEY_NAMES)."""


@dataclass(frozen=True)
class RemoteState:
    """One decoded remote frame: the keys held and the sticks (each axis -1..1; ``l2`` the trigger 0..1)."""

    keys: frozenset[str] = frozenset()
    lx: float = 0.0
    rx: float = 0.0
    ry: float = 0.0
    l2: float = 0.0
    ly: float = 0.0

    def held(self, *names: str) -> bool:
        """All of these keys are held (e.g. ``held("L2", "B")``)."""
        return key_mask(names) & key_mask(self.keys) == key_mask(names)


def key_mask(names: Iterable[str]) -> int:
    """The 16-bit key field with these keys held; raises UnknownKeyError for a name not in KEY_NAMES."""
    mask = 0
    for name in names:
        bit = KEY_BIT.get(name)
        if bit is None:
            raise UnknownKeyError(f"unknown remote key {name!r}; keys: {', '.join(KEY_NAMES)}")
        mask |= 1 << bit
    return mask


def keys_of(mask: int) -> frozenset[str]:
    """The key names held in a 16-bit key field."""
    return frozenset(name for bit, name in enumerate(KEY_NAMES) if mask >> bit & 1)


def encode_remote(state: RemoteState) -> bytes:
    """The 40 bytes of ``wireless_remote`` for this remote state (header and idle bytes zero)."""
    out = bytearray(REMOTE_SIZE)
    _KEYS.pack_into(out, _KEYS_AT, key_mask(state.keys))
    _AXES.pack_into(out, _AXES_AT, state.lx, state.rx, state.ry, state.l2, state.ly)
    return bytes(out)


def decode_remote(data: bytes | bytearray | Iterable[int]) -> RemoteState:
    """Decode ``wireless_remote``: the raw bytes, or the list of ints a deserialised LowState_ holds."""
    raw = data if isinstance(data, bytes | bytearray) else bytes(data)
    if len(raw) != REMOTE_SIZE:
        raise ValueError(f"wireless_remote has {REMOTE_SIZE} bytes, got {len(raw)}")
    (mask,) = _KEYS.unpack_from(raw, _KEYS_AT)
    lx, rx, ry, l2, ly = _AXES.unpack_from(raw, _AXES_AT)
    return RemoteState(keys_of(mask), lx, rx, ry, l2, ly)
