"""Replies taken as bytes: the decoding equals cyclonedds' own deserialisation; malformed bytes are refused."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from unitree_sdk2py.idl.unitree_api.msg.dds_ import RequestIdentity_, Response_, ResponseHeader_, ResponseStatus_

from g1_mode_manager.sdk.response_reader import Reply, decode

int64 = st.integers(-(2**63), 2**63 - 1)
int32 = st.integers(-(2**31), 2**31 - 1)


def serialised(request_id: int, api_id: int, code: int, data: str, binary: list[int] | None = None) -> bytes:
    header = ResponseHeader_(RequestIdentity_(request_id, api_id), ResponseStatus_(code))
    return Response_(header, data, binary or []).serialize()


@settings(max_examples=200, deadline=None)
@given(int64, int64, int32, st.text(max_size=300).map(lambda t: t.replace("\0", "")),
       st.lists(st.integers(0, 255), max_size=20))
def test_decoding_equals_cyclonedds_deserialisation(request_id: int, api_id: int, code: int, data: str,
                                                    binary: list[int]) -> None:
    raw = serialised(request_id, api_id, code, data, binary)
    expected = Response_.deserialize(raw)
    assert expected.data == data  # the reference itself round-trips
    assert decode(raw) == (request_id, Reply(api_id, code, data))


@pytest.mark.parametrize("raw", [b"", b"\x00\x01\x00\x00" + b"\x00" * 20, b"\x00\x03" + b"\x00" * 40,
                                 serialised(1, 7001, 0, "abc")[:-10]])
def test_malformed_replies_raise_value_error(raw: bytes) -> None:
    with pytest.raises(ValueError):
        decode(raw)


def test_a_closed_client_takes_no_reply_into_python(sdk_channels: int) -> None:
    """Closing stops Cyclone calling the reply listener: a late reply that arrives while the process exits
    must find no Python to call (it crashed nodes at exit)."""
    from unitree_sdk2py.core.channel import ChannelPublisher

    from g1_mode_manager.sdk.loco_client import LocoClient
    from support.mode_manager import wait_until

    client = LocoClient(1.0)
    replies = client._replies  # the reader under test
    server = ChannelPublisher("rt/api/sport/response", Response_)
    server.Init()

    def answer(request_id: int) -> None:
        server.Write(Response_(ResponseHeader_(RequestIdentity_(request_id, 7001), ResponseStatus_(0)), "{}", []))

    before = replies.expect(1)
    assert wait_until(lambda: (answer(1) or True) and before.done.is_set(), 5.0), "no reply taken before close"
    client.close()
    assert replies.expect(2).closed, "a call after close must end at once, not wait for a reply"
    from g1_mode_manager.sdk.response_reader import Pending

    watch = replies._pending[3] = Pending()  # what the listener would wake, were Cyclone still calling it
    for _ in range(20):
        answer(3)
    assert not watch.done.wait(0.5), "a reply was taken after close"
