"""An RPC client's requests written as ready-made CDR bytes, on the SDK's own request writer.

cyclonedds-python serialises a ``unitree_api`` Request_ (nested header structs, a string, an empty
sequence) through its generic IDL machinery, which costs more per message than struct packing, in front
of every Move and of the e-stop's Damp. The layout is fixed: three int64 (request id,
api id, lease id), an int32 priority and a bool no-reply flag, then the JSON parameter as a CDR string
and an empty binary sequence. ``struct`` packs that directly. The writer checks once, at
creation, that its bytes equal cyclonedds' own serialisation of the same request, and otherwise is not
used (the client then writes Request_ objects on the same writer, through cyclonedds' serialiser).
"""

from __future__ import annotations

import logging
import struct
import time
from collections.abc import Callable
from typing import Any, Final

from unitree_sdk2py.idl.unitree_api.msg.dds_ import (
    Request_,
    RequestHeader_,
    RequestIdentity_,
    RequestLease_,
    RequestPolicy_,
)

from g1_mode_manager.protocol.cyclone_internals import write_serialized, writer_use_version_2
from g1_mode_manager.protocol.unitree_sdk_internals import (
    channel_datawriter,
    channel_matched_readers,
    client_request_channel,
)

_log = logging.getLogger(__name__)

_HEADER: Final = struct.Struct("<qqqi?3x")  # identity.id, identity.api_id, lease.id, policy.priority, noreply
_EMPTY_BINARY: Final = b"\0\0\0\0"  # sequence<uint8> of length 0
#: The SDK waits for a matched server in steps of this long (ChannelPublisher.Write).
MATCH_POLL_S: Final = 0.1


def make_request(request_id: int, api_id: int, parameter: str, noreply: bool) -> Request_:
    """The same request as the SDK's Request_ object (lease 0, priority 0, no binary)."""
    header = RequestHeader_(RequestIdentity_(request_id, api_id), RequestLease_(0), RequestPolicy_(0, noreply))
    return Request_(header, parameter, [])


def encode(cdr_header: bytes, request_id: int, api_id: int, parameter: str, noreply: bool) -> bytes:
    """The serialised Request_: encapsulation header, header struct, parameter string, empty binary."""
    text = parameter.encode("utf-8") + b"\0"
    pad = -len(text) % 4  # the sequence's length is 4-aligned
    return b"".join((cdr_header, _HEADER.pack(request_id, api_id, 0, 0, noreply), len(text).to_bytes(4, "little"),
                     text, b"\0" * pad, _EMPTY_BINARY))


class RequestWriter:
    """Writes one client's requests on the SDK's own request DataWriter (same topic, QoS, participant)."""

    def __init__(self, client_stub: Any) -> None:
        self._channel = client_request_channel(client_stub)  # the SDK's send channel: the DataWriter, the match count
        self._writer = channel_datawriter(self._channel)
        self._header = b""
        self._raw = self._raw_write_function()

    @property
    def fast(self) -> bool:
        return self._raw is not None

    def matched(self) -> bool:
        """A server's request reader is matched (what the SDK's Write polls for)."""
        return channel_matched_readers(self._channel) > 0

    def _raw_write_function(self) -> Callable[[Any, bytes], bool] | None:
        try:
            probes = [(1_700_000_000_123_456_789, 7105, '{"velocity": [0.3, -0.1, 0.5], "duration": 1.0}', False),
                      (42, 7101, '{"data": 1}', True), (3, 1001, "", False), (4, 1002, '{"name": "ai"}', False),
                      (5, 1010, '{"text": "é, ü"}', False)]
            for probe in probes:
                expected = make_request(*probe).serialize(use_version_2=writer_use_version_2(self._writer))
                expected = expected.ljust((len(expected) + 3) & ~3, b"\0")
                self._header = expected[:4]
                if encode(self._header, *probe) != expected:
                    _log.warning("Request_ bytes differ from cyclonedds' for %r: writing through its serialiser", probe)
                    return None
            return write_serialized
        except Exception:  # an incompatible cyclonedds: the SDK's path
            _log.exception("raw Request_ writing unavailable")
            return None

    def write(self, request_id: int, api_id: int, parameter: str, noreply: bool, match_timeout_s: float | None) -> bool:
        """Write one request; False if no server matched within ``match_timeout_s`` (None: no wait) or
        DDS refused it. Waits for a match as the SDK does (polling every 0.1 s)."""
        if match_timeout_s is not None:
            waited = 0.0
            while not self.matched():
                if waited >= match_timeout_s:
                    return False
                time.sleep(MATCH_POLL_S)
                waited += MATCH_POLL_S
        try:
            if self._raw is not None:
                return self._raw(self._writer, encode(self._header, request_id, api_id, parameter, noreply))
            self._writer.write(make_request(request_id, api_id, parameter, noreply))
            return True
        except Exception:
            _log.exception("request write failed")
            return False
