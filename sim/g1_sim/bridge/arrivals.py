"""When an RPC request reached this process, stamped in Cyclone's receive thread (for the sim's record).

The SDK's RPC server hands a request through three Python threads before its handler runs (Cyclone's
listener deserialises and queues it, the channel's ``ch_reader`` thread moves it to the server's queue,
``server_queue`` dispatches it). Each hop waits for the GIL, which the physics thread holds for milliseconds at a
time, so a stamp taken in the handler can be late by several ms and two services' stamps can come out in the wrong
order. A robot receives when DDS delivers.

An ``Arrivals`` is a second reader on the same topic (same QoS, the SDK's participant) whose listener
takes the raw samples and notes ``time.monotonic()`` with a key read from the bytes (the request's identity id, which
every client makes unique), in arrival order. The handler, which sees the samples in the same order, pops the stamp of
its sample: the first one with its key, dropping the older ones (samples the SDK's queues dropped). Only
the last ``window`` stamps are kept: a sample being handled arrived at most that many samples ago (the
SDK's queues hold fewer). Without a stamp (the listener lost the race) the handler stamps itself: late, never early.

Frames are not stamped this way: identical frames (a held pose) have no key that tells them apart, so the sim takes
them itself where Cyclone delivers (frame_reader.py).
"""

from __future__ import annotations

import struct
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Final

from cyclonedds.core import Listener
from cyclonedds.sub import DataReader

from g1_mode_manager.protocol.cyclone_internals import take_serialized
from g1_mode_manager.protocol.dds import sdk_participant

_TAKE_MAX: Final = 16
#: Listeners Cyclone may still call are kept for the life of the process (freeing one can crash a DDS thread).
_NEVER_FREED: list[Any] = []

Key = Callable[[bytes], int | None]


def request_id(raw: bytes) -> int | None:
    """A serialised unitree_api Request_'s header.identity.id (the first int64 after the CDR header)."""
    if len(raw) < 12 or raw[0] != 0:
        return None
    return struct.unpack_from("<q" if raw[1] & 1 else ">q", raw, 4)[0]


class Arrivals:
    """Receive times of one topic's samples, noted in Cyclone's receive thread, popped by key in order."""

    def __init__(self, like: Any, key: Key, window: int) -> None:
        """A reader like ``like`` (an SDK reader: same topic and QoS, on the SDK's participant)."""
        self._key = key
        self._lock = threading.Lock()
        self._stamps: deque[tuple[int, float]] = deque(maxlen=window)
        self._listener = Listener(on_data_available=self._on_data)
        _NEVER_FREED.append(self._listener)
        self._reader = DataReader(sdk_participant(), like.topic, like.get_qos(), self._listener)

    def pop(self, key: int) -> float | None:
        """The receive time of the oldest kept sample with this key (older ones are dropped), or None."""
        with self._lock:
            for i, (k, t) in enumerate(self._stamps):
                if k == key:
                    for _ in range(i + 1):
                        self._stamps.popleft()
                    return t
            return None

    def _on_data(self, _reader: Any) -> None:
        t = time.monotonic()
        while True:
            taken = take_serialized(self._reader, _TAKE_MAX)
            if not taken:
                return
            with self._lock:
                for raw, info in taken:
                    key = self._key(raw) if info.valid_data else None
                    if key is not None:
                        self._stamps.append((key, t))
            if len(taken) < _TAKE_MAX:
                return
