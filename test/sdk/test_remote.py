"""The remote's 40 bytes in LowState_.wireless_remote: what we encode is what Unitree's layout decodes."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowState_

from g1_mode_manager.protocol.dds import apply_robot_type_compat
from g1_mode_manager.protocol.idl import LowState_
from g1_mode_manager.protocol.remote import (
    KEY_NAMES,
    REMOTE_SIZE,
    RemoteState,
    UnknownKeyError,
    decode_remote,
    encode_remote,
    key_mask,
    keys_of,
)

axis = st.floats(-1.0, 1.0, width=32)


@given(st.frozensets(st.sampled_from(KEY_NAMES)), axis, axis, axis, st.floats(0.0, 1.0, width=32), axis)
def test_encode_decode_round_trip(keys: frozenset[str], lx: float, rx: float, ry: float, l2: float, ly: float) -> None:
    state = RemoteState(keys, lx, rx, ry, l2, ly)
    data = encode_remote(state)
    assert len(data) == REMOTE_SIZE
    assert decode_remote(data) == state
    assert decode_remote(list(data)) == state  # as a deserialised LowState_ holds it


def test_layout_is_unitrees() -> None:
    """The bytes Unitree's own decoders read (rl_gym remote_controller.py, gamepad.hpp's union)."""
    data = encode_remote(RemoteState(frozenset({"R1", "B", "left"}), lx=0.25, rx=-0.5, ry=0.75, l2=1.0, ly=-1.0))
    keys = struct.unpack("<H", data[2:4])[0]
    assert keys == (1 << 0) | (1 << 9) | (1 << 15)  # R1 bit 0, B bit 9, left bit 15
    assert data[2] == 0b0000_0001 and data[3] == 0b1000_0010  # byte 2: R1..F2, byte 3: A..left
    assert struct.unpack("<5f", data[4:24]) == (0.25, -0.5, 0.75, 1.0, -1.0)  # lx, rx, ry, L2, ly
    assert data[:2] == b"\0\0" and data[24:] == bytes(16)


def test_bit_order_and_names() -> None:
    assert KEY_NAMES[:6] == ("R1", "L1", "start", "select", "R2", "L2")
    assert KEY_NAMES[8:] == ("A", "B", "X", "Y", "up", "right", "down", "left")
    assert key_mask(["L2", "B"]) == 0x0220 and keys_of(0x0220) == {"L2", "B"}
    assert RemoteState(frozenset({"L2", "B", "X"})).held("L2", "B")
    assert not RemoteState(frozenset({"L2"})).held("L2", "B")


def test_unknown_keys_and_sizes_are_refused() -> None:
    with pytest.raises(UnknownKeyError, match="'l2'"):
        key_mask(["l2"])
    with pytest.raises(ValueError, match="40 bytes"):
        decode_remote(bytes(39))


def test_survives_a_lowstate_round_trip() -> None:
    apply_robot_type_compat()
    msg = unitree_hg_msg_dds__LowState_()
    state = RemoteState(frozenset({"L2", "B"}), l2=1.0, ly=0.5)
    msg.wireless_remote = list(encode_remote(state))
    assert decode_remote(LowState_.deserialize(msg.serialize()).wireless_remote) == state
