"""The flight ring: the node's own recent past, bounded in count per kind, cheap to add to from any thread.

``add`` is one clock read, one counter step and one ``deque.append`` (atomic under the GIL): no lock, so no hook
ever waits for the writer or for another hook. Each kind keeps at most ``caps[kind]`` events (the oldest go
first); ``caps_for`` sizes them for a window from the most each kind is expected to produce per second, so the
whole window stays in memory unless a kind runs faster than that, and then only that kind's oldest go.

The caps are sized for each kind's busiest rate, which an ordinary load reaches seldom: by count alone a ring
would keep filling for minutes (a node's memory rising by megabytes long after its start). ``prune`` drops what is
older than the window, so the ring holds the window's events and no more; the recorder's own thread calls it.
"""

from __future__ import annotations

import itertools
import math
import time
from collections import deque
from collections.abc import Callable, Mapping
from typing import Final

from g1_mode_manager.core.recorder.events import Event, Kind

#: (when it was added, its place in the order of adding, the event).
Entry = tuple[float, int, Event]

#: The most events of each kind a second the ring keeps for a whole window (a kind running faster keeps a shorter
#: past). BODY is the body check's rate (body_check_rate_hz) and FRAME three topics at the frame rate: both are
#: replaced by the node's own rates.
RATES_HZ: Final[Mapping[Kind, float]] = {
    Kind.STATUS: 20.0,  # changes only: an e-stop makes about five
    Kind.TRANSITION: 10.0,
    Kind.NOTE: 10.0,  # log lines, each key at most once in 2 s
    Kind.SERVICE: 10.0,
    Kind.CALL: 150.0,  # request and answer: Moves at cmd_vel_max_rate_hz (50) and the supervision's checks
    Kind.BODY: 100.0,
    Kind.DRIVE: 150.0,  # the teleop and the autonomy at up to 100 and 50 Hz
    Kind.MOVE: 50.0,  # cmd_vel_max_rate_hz
    Kind.ESTOP: 10.0,
    Kind.FRAME: 30.0,
    Kind.ODOMETRY: 20.0,  # rt/lf/odommodestate's rate: each sample is kept once, however often it is read
}
#: What an event of each kind takes in memory, bytes: the entry, the event and what it keeps alive, measured with
#: tracemalloc on 10 000 events as the node makes them (a note's or an answer's text of a usual length) in a fresh
#: process (in one that has made garbage, the interpreter's free lists hide the first thousands of tuples).
#: ``approx_bytes`` counts with it, for /diagnostics and the soak: the ring's content told from the rest of the
#: node's memory.
BYTES_PER_EVENT: Final[Mapping[Kind, int]] = {
    Kind.STATUS: 380,
    Kind.TRANSITION: 371,
    Kind.NOTE: 301,
    Kind.SERVICE: 247,
    Kind.CALL: 476,
    Kind.BODY: 501,
    Kind.DRIVE: 268,
    Kind.MOVE: 260,
    Kind.ESTOP: 270,
    Kind.FRAME: 1437,  # 29 joints' five numbers packed in an array
    Kind.ODOMETRY: 508,
}
#: Kinds whose last event before a window still holds at its start: the file keeps it, so it says the mode the
#: window began in.
STATE_KINDS: Final = (Kind.STATUS,)


def caps_for(span_s: float, rates_hz: Mapping[Kind, float] = RATES_HZ) -> dict[Kind, int]:
    """Events of each kind that ``span_s`` seconds at ``rates_hz`` make (at least one)."""
    if not span_s > 0.0:
        raise ValueError(f"the recorder's span must be > 0 s, got {span_s}")
    return {kind: max(1, math.ceil(span_s * rates_hz[kind])) for kind in Kind}


class FlightRing:
    def __init__(self, caps: Mapping[Kind, int], clock: Callable[[], float] = time.monotonic) -> None:
        self.caps = dict(caps)
        self._rings: dict[Kind, deque[Entry]] = {kind: deque(maxlen=self.caps[kind]) for kind in Kind}
        self._order = itertools.count()
        self._clock = clock

    def add(self, event: Event, at: float | None = None) -> None:
        """``at``: when it happened on the ring's clock, if not now (a reading that the step it began acted on)."""
        self._rings[event.kind].append((self._clock() if at is None else at, next(self._order), event))

    def entries(self, start: float, end: float) -> list[Entry]:
        """Every kept entry added from ``start`` to ``end``, in the order they were added (time, then order), and
        of each of STATE_KINDS the last one before ``start``."""
        out: list[Entry] = []
        for kind, ring in self._rings.items():
            kept = _copy(ring)
            inside = [e for e in kept if start <= e[0] <= end]
            if kind in STATE_KINDS:
                before = [e for e in kept if e[0] < start]
                inside[:0] = before[-1:]
            out.extend(inside)
        out.sort(key=lambda e: (e[0], e[1]))
        return out

    def prune(self, before: float) -> int:
        """Drop the entries added before ``before`` (of each of STATE_KINDS the last one stays, as ``entries`` wants
        it); how many went. Call it from one thread only: the hooks only append. An append that finds its kind at
        its cap drops that kind's oldest meanwhile, so a prune racing it may take the next oldest instead: one entry
        at the window's far edge, in a kind that runs at its cap."""
        dropped = 0
        for kind, ring in self._rings.items():
            keep = 1 if kind in STATE_KINDS else 0  # a state kind's last entry before the cut says what then held
            while len(ring) > keep and ring[keep][0] < before:
                ring.popleft()
                dropped += 1
        return dropped

    def counts(self) -> dict[Kind, int]:
        return {kind: len(ring) for kind, ring in self._rings.items()}

    def approx_bytes(self) -> int:
        """The memory the kept events take, by BYTES_PER_EVENT: within a quarter of it for events of usual size."""
        return sum(n * BYTES_PER_EVENT[kind] for kind, n in self.counts().items())


def _copy(ring: deque[Entry]) -> list[Entry]:
    """A copy of ``ring`` while other threads append to it: ``list`` copies it in C without running Python (so
    without a thread switch); the retry is for an interpreter that switches anyway."""
    for _ in range(3):
        try:
            return list(ring)
        except RuntimeError:  # deque mutated during iteration
            continue
    return list(ring)
