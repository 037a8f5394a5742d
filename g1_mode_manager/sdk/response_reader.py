"""An RPC client's replies taken as bytes, decoded with ``struct`` and handed to the call waiting for them.

The SDK's ``ClientStub`` receives every reply through a cyclonedds listener that deserialises a whole
Response_ with the generic IDL machinery, queues it, and lets a thread of its own ("ch_reader") resolve
a future: two Python hops and the generic deserialiser per reply, for every Move acknowledgement, LED
colour and supervision check, and for every reply to *other* clients of the same service (the response
topic is shared). Here one reader on the same topic with the same QoS takes the raw sample in Cyclone's
receive thread, unpacks it with ``struct`` (far cheaper) and wakes the call of this client that waits
for its request id, if any. The layout is fixed (request id, api id: int64; status code: int32; data:
string; binary: sequence<uint8>); the reader checks once, at creation, that its decoding of cyclonedds'
own serialisation is right, and otherwise deserialises Response_ objects.
"""

from __future__ import annotations

import logging
import struct
import threading
from typing import Any, Final, NamedTuple

from cyclonedds.core import Listener
from cyclonedds.sub import DataReader
from unitree_sdk2py.idl.unitree_api.msg.dds_ import (
    RequestIdentity_,
    Response_,
    ResponseHeader_,
    ResponseStatus_,
)

from g1_mode_manager.protocol.cyclone_internals import held_listener, take_serialized
from g1_mode_manager.protocol.dds import sdk_participant
from g1_mode_manager.protocol.unitree_sdk_internals import channel_datareader, client_response_channel

_log = logging.getLogger(__name__)
_IDS_LE: Final = struct.Struct("<qqi")  # identity.id, identity.api_id, status.code
_IDS_BE: Final = struct.Struct(">qqi")
_TAKE_MAX: Final = 16
#: Listeners Cyclone may still call: kept for the life of the process (freeing one can crash a DDS thread).
_NEVER_FREED: list[Any] = []


class Reply(NamedTuple):
    api_id: int
    code: int
    data: str


def decode(raw: bytes) -> tuple[int, Reply]:
    """(request id, reply) of a serialised Response_ (plain CDR, either byte order). ValueError if malformed."""
    if len(raw) < 28 or raw[0] != 0 or raw[1] not in (0, 1, 6, 7):
        raise ValueError("not a plain-CDR Response_")
    little = bool(raw[1] & 1)
    request_id, api_id, code = (_IDS_LE if little else _IDS_BE).unpack_from(raw, 4)
    size = int.from_bytes(raw[24:28], "little" if little else "big")  # includes the terminating NUL
    if size < 1 or 28 + size > len(raw):
        raise ValueError("Response_ data string out of bounds")
    return request_id, Reply(api_id, code, raw[28 : 28 + size - 1].decode("utf-8"))


def _decode_slow(raw: bytes) -> tuple[int, Reply]:
    response = Response_.deserialize(raw)
    identity = response.header.identity
    return int(identity.id), Reply(int(identity.api_id), int(response.header.status.code), response.data)


class Pending:
    """One call waiting for its reply."""

    __slots__ = ("closed", "done", "reply")

    def __init__(self) -> None:
        self.done = threading.Event()
        self.reply: Reply | None = None
        self.closed = False  # woken by close(): no reply will come


class ResponseReader:
    """Replaces the SDK stub's response reader (same topic and QoS) for one client.

    ``expect(id)`` before the request is written, ``wait(pending, timeout)`` for the reply, ``forget(id)``
    when the call gives up. Replies nobody expects (other clients', late ones) are dropped.
    """

    def __init__(self, client_stub: Any) -> None:
        sdk_reader = channel_datareader(client_response_channel(client_stub))
        self._lock = threading.Lock()
        self._pending: dict[int, Pending] = {}
        self._decode = decode if self._decoding_is_exact() else _decode_slow
        self.fast = self._decode is decode
        self._errors = 0
        self.closed = False
        self._listener = Listener(on_data_available=self._on_data)
        _NEVER_FREED.append(self._listener)
        self._reader = DataReader(sdk_participant(), sdk_reader.topic, sdk_reader.get_qos(), self._listener)
        # The SDK's reader stops calling Python: its listener is removed, but the Python object behind it is
        # kept (cyclonedds frees it before Cyclone stops using it; Cyclone's threads then call freed memory:
        # a SIGSEGV in a 'gc' thread seen in a full run when the reader itself was closed).
        _NEVER_FREED.append(held_listener(sdk_reader))
        sdk_reader.set_listener(None)

    @staticmethod
    def _decoding_is_exact() -> bool:
        try:
            for probe in ((1_700_000_000_123_456_789, 7001, 0, '{"data":500}'), (-5, 1001, 3104, ""),
                          (7, 1010, -1, '{"text": "é ü"}'), (8, 1002, 7301, "abc")):
                request_id, api_id, code, data = probe
                response = Response_(ResponseHeader_(RequestIdentity_(request_id, api_id), ResponseStatus_(code)),
                                     data, [])
                if decode(response.serialize()) != (request_id, Reply(api_id, code, data)):
                    _log.warning("Response_ decoding differs from cyclonedds' for %r: using its deserialiser", probe)
                    return False
            return True
        except Exception:
            _log.exception("fast Response_ decoding unavailable")
            return False

    def expect(self, request_id: int) -> Pending:
        pending = Pending()
        with self._lock:
            if self.closed:
                pending.closed = True
                pending.done.set()
            else:
                self._pending[request_id] = pending
        return pending

    def forget(self, request_id: int) -> None:
        with self._lock:
            self._pending.pop(request_id, None)

    @staticmethod
    def wait(pending: Pending, timeout_s: float) -> Reply | None:
        return pending.reply if pending.done.wait(timeout_s) else None

    @property
    def errors(self) -> int:
        """Samples that could not be decoded (dropped)."""
        return self._errors

    def _on_data(self, _reader: Any) -> None:
        """In Cyclone's receive thread: take what is there, wake the calls it answers."""
        try:
            while True:
                taken = take_serialized(self._reader, _TAKE_MAX)
                if not taken:
                    return
                for raw, info in taken:
                    if info.valid_data:
                        self._deliver(raw)
                if len(taken) < _TAKE_MAX:
                    return
        except Exception:  # never raise into the DDS receive thread
            self._errors += 1
            _log.exception("reply reader failed")

    def _deliver(self, raw: bytes) -> None:
        try:
            request_id, reply = self._decode(raw)
        except (ValueError, UnicodeDecodeError, struct.error):
            self._errors += 1
            return
        with self._lock:
            pending = self._pending.pop(request_id, None)
        if pending is not None:
            pending.reply = reply
            pending.done.set()

    def close(self) -> None:
        """No more calls into Python from Cyclone's receive thread: a reply that arrives while the process
        exits (a late answer to a call that timed out) would otherwise call a listener after the
        interpreter is gone (a SIGSEGV at exit). The listener object itself stays alive (_NEVER_FREED).
        Calls waiting for a reply, and every later one, end at once (``Pending.closed``)."""
        with self._lock:  # first wake the waiting calls: one may hold up the process's exit for its whole timeout
            self.closed = True
            waiting, self._pending = list(self._pending.values()), {}
        for pending in waiting:
            pending.closed = True
            pending.done.set()
        self._reader.set_listener(None)  # Cyclone waits for a callback that is running
