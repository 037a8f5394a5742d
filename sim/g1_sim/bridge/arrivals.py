"""When a sample reached this process, stamped in Cyclone's receive thread (for the sim's record).

The SDK's RPC server hands a request through three Python threads before its handler runs (Cyclone's
listener deserialises and queues it, the channel's ``ch_reader`` thread moves it to the server's queue,
``server_queue`` dispatches it); rt/lowcmd and rt/arm_sdk frames pass two. Each hop waits for the GIL,
which the physics thread holds for milliseconds at a time, so a stamp taken in the handler can be late by
several ms and two topics' stamps can come out in the wrong order. A robot receives when DDS delivers.

An ``Arrivals`` is a second reader on the same topic (same QoS, the SDK's participant) whose listener
takes the raw samples and notes ``time.monotonic()`` with a key read from the bytes (a request's id, the
CRC of a frame's content), in arrival order. The handler, which sees the samples in the same order, pops the stamp of
its sample: the first one with its key, dropping the older ones (samples the SDK's queues dropped). Only
the last ``window`` stamps are kept: a sample being handled arrived at most that many samples ago (the
SDK's queues hold fewer). Without a stamp (the listener lost the race) the handler stamps itself:
late, never early. One case can be early: identical frames (same content) while the SDK's frame queue
overflows get the stamp of an identical frame that arrived up to ``window`` frames earlier.

A frame's key is the CRC of its content computed here, not its ``crc`` field: Unitree's arm_sdk examples
leave that field 0 in every frame (the robot does not check it on rt/arm_sdk), which would make all their
frames one key, and a stale or wrong field would not match what the handler computes. The handler
computes the same CRC anyway (to check rt/lowcmd), so both sides agree whatever the field holds.
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

from g1_mode_manager.protocol.crc import crc32_words
from g1_mode_manager.protocol.cyclone_internals import take_serialized
from g1_mode_manager.protocol.dds import sdk_participant

_TAKE_MAX: Final = 16
#: A unitree_hg LowCmd_ in CDR: the 4-byte encapsulation header, then 1000 bytes (its crc word last).
_LOWCMD_CDR_SIZE: Final = 4 + 1000
#: Little-endian plain CDR (XCDR1) and XCDR2: LowCmd_ (final, 4-byte aligned at most) lays out the same in both.
_LITTLE_ENDIAN_ENCODINGS: Final = (0x01, 0x07)
#: Listeners Cyclone may still call are kept for the life of the process (freeing one can crash a DDS thread).
_NEVER_FREED: list[Any] = []

Key = Callable[[bytes], int | None]


def request_id(raw: bytes) -> int | None:
    """A serialised unitree_api Request_'s header.identity.id (the first int64 after the CDR header)."""
    if len(raw) < 12 or raw[0] != 0:
        return None
    return struct.unpack_from("<q" if raw[1] & 1 else ">q", raw, 4)[0]


def lowcmd_content_crc(raw: bytes) -> int | None:
    """The CRC the robot would expect for a serialised LowCmd_ (``protocol.crc.lowcmd_crc`` of the same frame),
    computed from its bytes; None if they are not a little-endian LowCmd_.

    The C struct the CRC covers is the CDR body with motor 0's ``mode`` moved from offset 2 to 4 and
    everything from motor 0's ``q`` on shifted by 4 bytes (C pads the two header bytes to 4).
    """
    if len(raw) != _LOWCMD_CDR_SIZE or raw[0] != 0 or raw[1] not in _LITTLE_ENDIAN_ENCODINGS:
        return None
    c = bytearray(1000)
    c[0:2] = raw[4:6]  # mode_pr, mode_machine
    c[4] = raw[6]  # motor 0's mode
    c[8:] = raw[8 : _LOWCMD_CDR_SIZE - 4]  # motor 0's q on, the crc word left out
    return crc32_words(bytes(c))


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
