"""Request_ as ready-made bytes: equal to cyclonedds' own serialisation for any id, api id, parameter, flag."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from g1_mode_manager.sdk.request_writer import encode, make_request

int64 = st.integers(-(2**63), 2**63 - 1)


@settings(max_examples=200, deadline=None)
@given(int64, int64, st.text(max_size=300), st.booleans())
def test_encoded_request_equals_cyclonedds_serialisation(request_id: int, api_id: int, parameter: str,
                                                        noreply: bool) -> None:
    parameter = parameter.replace("\0", "")  # a CDR string ends at its first NUL; JSON never holds one
    expected = make_request(request_id, api_id, parameter, noreply).serialize()
    expected = expected.ljust((len(expected) + 3) & ~3, b"\0")  # as cyclonedds' DataWriter.write pads it
    assert encode(expected[:4], request_id, api_id, parameter, noreply) == expected


def test_encoded_request_decodes_to_the_same_request() -> None:
    from unitree_sdk2py.idl.unitree_api.msg.dds_ import Request_

    data = encode(make_request(0, 0, "", False).serialize()[:4], 123, 7105, '{"velocity": [0.3, 0, 0]}', True)
    request = Request_.deserialize(data)
    assert (request.header.identity.id, request.header.identity.api_id) == (123, 7105)
    assert request.header.policy.noreply is True and request.header.lease.id == 0
    assert request.parameter == '{"velocity": [0.3, 0, 0]}' and list(request.binary) == []
