"""Every rt/lowcmd, rt/user_lowcmd and rt/arm_sdk frame DDS delivered to the sim, handled in arrival order, each
with its own receive stamp and arrival number.

A robot's firmware is C++: it receives every frame DDS delivers. The SDK's Python reader takes one sample per
notification out of a one-deep history and, behind a queue, drops every new frame beyond its length; a loaded
machine lost a fifth of a 500 Hz stream there, and the sim's record, which the tests judge by, lost them with it.
Its receive stamps, taken by a second reader, had to be matched to frames by content, which identical frames (a held
pose) make ambiguous.

Here Cyclone's receive thread only takes the undecoded samples and notes when they came (no decoding, no lock but
the backlog's); one handler thread per topic decodes and handles them in arrival order. A backlog longer than
``MAX_BACKLOG`` (the handler starved for seconds) drops the newest frames and counts them, never silently: the
handler learns of each drop before the next frame it gets, and the record says so (``drop``).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Final

from cyclonedds.core import Listener
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from g1_mode_manager.protocol.cyclone_internals import take_serialized
from g1_mode_manager.protocol.dds import sdk_participant
from g1_mode_manager.protocol.idl import LowCmd_

log = logging.getLogger(__name__)

#: Frames that may wait for the handler: 10 s of a 500 Hz stream. The deepest backlog a loaded suite's sim has shown is
#: in docs/sim.md; a starved handler catches up through it in order.
MAX_BACKLOG: Final = 5000
#: Cyclone's own history: it holds what came in while the listener was running, until the listener takes it.
_HISTORY_DEPTH: Final = 256
_TAKE_MAX: Final = 64
#: Listeners Cyclone may still call are kept for the life of the process (freeing one can crash a DDS thread).
_NEVER_FREED: list[Any] = []

#: handler(frame, receive time (CLOCK_MONOTONIC), arrival number on this topic counted from 1, when its writer wrote it
#: (its DDS source timestamp, the writer's CLOCK_REALTIME, as this process's CLOCK_MONOTONIC: on one machine the write))
Handler = Callable[[LowCmd_, float, int, float], object]
#: on_drop(first arrival number dropped, how many in a row)
DropHook = Callable[[int, int], None]


class FrameReader:
    """One command topic's frames: taken where Cyclone delivers, handled in order on a thread of their own."""

    def __init__(self, topic: str, handler: Handler, *, on_drop: DropHook | None = None,
                 max_backlog: int = MAX_BACKLOG) -> None:
        self.topic = topic
        self._handler = handler
        self._on_drop = on_drop
        self._max_backlog = max_backlog
        self._cond = threading.Condition()
        self._backlog: deque[tuple[int, float, bytes, float]] = deque()
        self._arrived = 0
        self._drops: list[list[int]] = []  # [first number, count] of each run of dropped frames not yet reported
        self._dropped = 0
        self._deepest = 0
        self._stopped = False
        self._thread = threading.Thread(target=self._run, name=f"frames {topic}", daemon=True)
        self._thread.start()
        participant = sdk_participant()
        self._listener = Listener(on_data_available=self._on_data)
        _NEVER_FREED.append(self._listener)
        qos = Qos(Policy.History.KeepLast(_HISTORY_DEPTH))
        self._reader = DataReader(participant, Topic(participant, topic, LowCmd_), qos, self._listener)

    def stats(self) -> dict[str, int]:
        """Frames arrived, dropped, and the deepest backlog so far."""
        with self._cond:
            return {"arrived": self._arrived, "dropped": self._dropped, "deepest": self._deepest}

    def stop(self) -> None:
        with self._cond:
            self._stopped = True
            self._cond.notify()
        self._thread.join(timeout=2.0)

    def _on_data(self, _reader: Any) -> None:
        t = time.monotonic()
        realtime_ahead = time.time() - t
        while True:
            taken = take_serialized(self._reader, _TAKE_MAX)
            if not taken:
                return
            with self._cond:
                for raw, info in taken:
                    if not info.valid_data:
                        continue
                    self._arrived += 1
                    if len(self._backlog) < self._max_backlog:
                        self._backlog.append((self._arrived, t, raw, info.source_timestamp * 1e-9 - realtime_ahead))
                        self._deepest = max(self._deepest, len(self._backlog))
                    else:
                        self._dropped += 1
                        if self._drops and sum(self._drops[-1]) == self._arrived:
                            self._drops[-1][1] += 1
                        else:
                            self._drops.append([self._arrived, 1])
                self._cond.notify()
            if len(taken) < _TAKE_MAX:
                return

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._backlog and not self._drops and not self._stopped:
                    self._cond.wait()
                if self._stopped:
                    return
                frames = list(self._backlog)
                self._backlog.clear()
                drops, self._drops = self._drops, []
            for n, t, raw, written in frames:
                # a run of drops is reported before the first frame that arrived after it
                while drops and drops[0][0] < n:
                    self._report_drop(*drops.pop(0))
                self._handle(n, t, raw, written)
            for first, count in drops:
                self._report_drop(first, count)

    def _report_drop(self, first: int, count: int) -> None:
        log.error("%d frames on %s dropped from number %d: the handler fell %d frames behind", count, self.topic,
                  first, self._max_backlog)
        if self._on_drop is not None:
            self._on_drop(first, count)

    def _handle(self, n: int, t: float, raw: bytes, written: float) -> None:
        """An exception would end this topic's handling for good: log it and go on."""
        try:
            self._handler(LowCmd_.deserialize(raw), t, n, written)
        except Exception:
            log.exception("frame %d on %s failed", n, self.topic)
