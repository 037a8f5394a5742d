"""The sim's receive stamps: taken where Cyclone delivers, keyed by what the handler can see, popped in order."""

from __future__ import annotations

import os
import time
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st
from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.unitree_api.msg.dds_ import Request_, RequestHeader_, RequestIdentity_, RequestLease_, RequestPolicy_

from g1_mode_manager.protocol.unitree_sdk_internals import (
    channel_datareader,
    channel_matched_readers,
    publisher_channel,
    subscriber_channel,
)
from g1_sim.bridge.arrivals import Arrivals, request_id
from support.mode_manager import wait_until


@settings(max_examples=100, deadline=None)
@given(st.integers(-(2**63), 2**63 - 1), st.integers(0, 2**31), st.text(max_size=50).map(lambda t: t.replace("\0", "")))
def test_request_id_is_the_header_identity_id(rid: int, api_id: int, parameter: str) -> None:
    header = RequestHeader_(RequestIdentity_(rid, api_id), RequestLease_(0), RequestPolicy_(0, False))
    assert request_id(Request_(header, parameter, []).serialize()) == rid


def test_malformed_samples_have_no_key() -> None:
    assert request_id(b"\x00\x01\x00") is None
    assert request_id(b"\x01\x01\x00\x00" + b"\x00" * 8) is None  # not plain CDR


#: SDK entities of this file's tests.
_KEPT: list[Any] = []


def _request(rid: int) -> Request_:
    header = RequestHeader_(RequestIdentity_(rid, 7101), RequestLease_(0), RequestPolicy_(0, False))
    return Request_(header, "{}", [])


def test_requests_are_stamped_on_delivery_and_popped_in_order(sdk_channels: int) -> None:
    topic = f"test/arrivals_{os.getpid()}"
    handled = []
    sub = ChannelSubscriber(topic, Request_)
    sub.Init(lambda msg: handled.append(msg.header.identity.id), 0)
    stamps = Arrivals(channel_datareader(subscriber_channel(sub)), request_id, window=4)
    pub = ChannelPublisher(topic, Request_)
    _KEPT.extend((sub, pub))  # never freed while the process lives (harness/sim_bridge.py: pitfall)
    pub.Init()
    assert wait_until(lambda: channel_matched_readers(publisher_channel(pub)) >= 2, 10.0)
    sent = []
    for rid in (1, 2, 3, 2, 4, 5):
        sent.append(time.monotonic())
        assert pub.Write(_request(rid), 1.0)
        time.sleep(0.01)
    assert wait_until(lambda: len(handled) == 6, 5.0)
    seen = time.monotonic()
    # only the last 4 (the window) are kept: 1 and the first 2 are gone
    assert stamps.pop(1) is None
    t3 = stamps.pop(3)
    assert t3 is not None and sent[2] <= t3 <= seen
    t2 = stamps.pop(2)  # the second request with id 2: the one after 3
    assert t2 is not None and sent[3] <= t2 < sent[4]
    assert stamps.pop(3) is None  # popped stamps and the ones before them are gone
    t5 = stamps.pop(5)  # 4 is skipped (a request the handler never saw) and dropped
    assert t5 is not None and sent[5] <= t5 <= seen
    assert stamps.pop(4) is None
