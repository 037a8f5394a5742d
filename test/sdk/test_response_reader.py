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
       st.lists(st.integers(0, 255), max_size=20))  # fmt: skip
def test_decoding_equals_cyclonedds_deserialisation(request_id: int, api_id: int, code: int, data: str,
                                                    binary: list[int]) -> None:  # fmt: skip
    raw = serialised(request_id, api_id, code, data, binary)
    expected = Response_.deserialize(raw)
    assert expected.data == data  # the reference itself round-trips
    assert decode(raw) == (request_id, Reply(api_id, code, data))


@pytest.mark.parametrize("raw", [b"", b"\x00\x01\x00\x00" + b"\x00" * 20, b"\x00\x03" + b"\x00" * 40,
                                 serialised(1, 7001, 0, "abc")[:-10]])  # fmt: skip
def test_malformed_replies_raise_value_error(raw: bytes) -> None:
    with pytest.raises(ValueError):
        decode(raw)
