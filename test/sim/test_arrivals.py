"""The sim's receive stamps: taken where Cyclone delivers, keyed by what the handler can see, popped in order."""

from __future__ import annotations

import os
import time
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st
from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
from unitree_sdk2py.idl.unitree_api.msg.dds_ import Request_, RequestHeader_, RequestIdentity_, RequestLease_, RequestPolicy_

from g1_mode_manager.protocol.crc import lowcmd_crc
from g1_mode_manager.protocol.unitree_sdk_internals import (
    channel_datareader,
    channel_matched_readers,
    publisher_channel,
    subscriber_channel,
)
from g1_sim.bridge.arrivals import Arrivals, lowcmd_content_crc, request_id
from support.mode_manager import wait_until


@settings(max_examples=100, deadline=None)
@given(st.integers(-(2**63), 2**63 - 1), st.integers(0, 2**31), st.text(max_size=50).map(lambda t: t.replace("\0", "")))
def test_request_id_is_the_header_identity_id(rid: int, api_id: int, parameter: str) -> None:
    header = RequestHeader_(RequestIdentity_(rid, api_id), RequestLease_(0), RequestPolicy_(0, False))
    assert request_id(Request_(header, parameter, []).serialize()) == rid


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-3.0, 3.0, width=32), st.integers(0, 255), st.integers(0, 255),
       st.integers(0, 2**32 - 1))
def test_a_lowcmds_key_is_the_crc_of_its_content_whatever_its_crc_field(crc: int, q: float, mode: int, mode_pr: int,
                                                                        reserve: int) -> None:
    msg = unitree_hg_msg_dds__LowCmd_()
    msg.mode_pr, msg.mode_machine = mode_pr, 5
    msg.motor_cmd[0].mode, msg.motor_cmd[0].q, msg.motor_cmd[3].q, msg.motor_cmd[34].kd = mode, q, -q, 2.5
    msg.motor_cmd[29].q = 0.5  # the arm_sdk weight
    msg.motor_cmd[7].reserve, msg.reserve[3] = reserve, reserve
    msg.crc = crc
    assert lowcmd_content_crc(msg.serialize()) == lowcmd_crc(msg)


def test_malformed_samples_have_no_key() -> None:
    assert request_id(b"\x00\x01\x00") is None and lowcmd_content_crc(b"") is None
    assert request_id(b"\x01\x01\x00\x00" + b"\x00" * 8) is None  # not plain CDR
    assert lowcmd_content_crc(b"\x00\x00\x00\x00" + bytes(1000)) is None  # big endian: the handler stamps itself


def _frame(value: float) -> Any:
    """A LowCmd_ as Unitree's arm_sdk examples send it: its crc field left 0, only its content differs."""
    msg = unitree_hg_msg_dds__LowCmd_()
    msg.motor_cmd[15].q = value
    return msg


def test_frames_are_stamped_on_delivery_and_popped_in_order(sdk_channels: int) -> None:
    topic = f"test/arrivals_{os.getpid()}"
    handled = []
    sub = ChannelSubscriber(topic, type(unitree_hg_msg_dds__LowCmd_()))
    sub.Init(lambda msg: handled.append(msg.crc), 0)
    stamps = Arrivals(channel_datareader(subscriber_channel(sub)), lowcmd_content_crc, window=4)
    pub = ChannelPublisher(topic, type(unitree_hg_msg_dds__LowCmd_()))
    pub.Init()
    assert wait_until(lambda: channel_matched_readers(publisher_channel(pub)) >= 2, 10.0)
    key = {v: lowcmd_crc(_frame(v)) for v in (1, 2, 3, 4, 5)}
    sent = []
    for v in (1, 2, 3, 2, 4, 5):
        sent.append(time.monotonic())
        assert pub.Write(_frame(v), 1.0)
        time.sleep(0.01)
    assert wait_until(lambda: len(handled) == 6, 5.0)
    assert handled == [0] * 6  # every crc field 0, every key different
    seen = time.monotonic()
    # only the last 4 (the window) are kept: 1 and the first 2 are gone
    assert stamps.pop(key[1]) is None
    t3 = stamps.pop(key[3])
    assert t3 is not None and sent[2] <= t3 <= seen
    t2 = stamps.pop(key[2])  # the second frame with content 2: the one after 3
    assert t2 is not None and sent[3] <= t2 < sent[4]
    assert stamps.pop(key[3]) is None  # popped stamps and the ones before them are gone
    t5 = stamps.pop(key[5])  # 4 is skipped (a frame the handler never saw) and dropped
    assert t5 is not None and sent[5] <= t5 <= seen
    assert stamps.pop(key[4]) is None
