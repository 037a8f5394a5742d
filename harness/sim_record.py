"""Read the sim's own record (``sim_bridge --record PATH``): what the robot received, and when.

Receive times are CLOCK_MONOTONIC, shared with the test process, so ``time.monotonic()`` taken in a
test can be compared with them directly. See ``g1_sim.bridge.record`` for the event kinds.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from g1_mode_manager.protocol import api_ids

Event = dict[str, Any]
DAMP_PARAMETER = {"data": 1}


class IncompleteRecordError(AssertionError):
    """The sim dropped frames that reached it (a ``drop`` event): what it did not look at is not on the record, so
    nothing may be judged by it. An AssertionError: a test reading such a record fails, it is not an error of its
    own."""


class SimRecord:
    """The events of one bridge's record file, read up to date on every call (the bridge appends while we
    read). Lines already read are kept, not parsed again: the record holds a ``body`` event every 10 ms of
    sim time, and tests poll it."""

    def __init__(self, path: str | Path, *, from_now: bool = False) -> None:
        """``from_now``: only what the bridge records from now on (a test sharing the bridge of its file)."""
        self.path = Path(path)
        self._events: list[Event] = []
        self._drop: Event | None = None  # the first ``drop`` read: from then on every read raises
        self._offset = self.path.stat().st_size if from_now and self.path.exists() else 0
        # The size may fall inside a line the bridge is writing (a reader can see part of a write to a file): the
        # rest of that line is before now, and is skipped rather than parsed as a line of its own.
        self._partial = self._offset > 0 and _byte_before(self.path, self._offset) != b"\n"

    def events(self, since: float = float("-inf")) -> list[Event]:
        self._read_new()
        return [e for e in self._events if e["t"] >= since]

    def _read_new(self) -> None:
        if not self.path.exists():
            return
        with self.path.open("rb") as f:
            if f.seek(0, 2) < self._offset:  # a new file at the same path: start over
                self._events, self._offset, self._drop = [], 0, None
            f.seek(self._offset)
            for line in f:
                if not line.endswith(b"\n"):
                    break  # a line still being written
                self._offset += len(line)
                if self._partial:
                    self._partial = False
                    continue
                event = json.loads(line)
                self._events.append(event)
                if event["k"] == "drop" and self._drop is None:
                    self._drop = event
        if self._drop is not None:
            raise IncompleteRecordError(f"the sim dropped frames it received, its record is not complete: {self._drop}")

    def after_last_reset(self) -> list[Event]:
        events = self.events()
        resets = [i for i, e in enumerate(events) if e["k"] == "reset"]
        return events[resets[-1] + 1 :] if resets else events


def _byte_before(path: Path, offset: int) -> bytes:
    with path.open("rb") as f:
        f.seek(offset - 1)
        return f.read(1)


def requests(events: Iterable[Event], api_id: int | None = None, kind: str = "req") -> list[Event]:
    return [e for e in events if e["k"] == kind and (api_id is None or e["api"] == api_id)]


def fsm_of(event: Event) -> int | None:
    """The fsm id a SetFsmId request asks for (None for other requests)."""
    if event.get("api") != api_ids.LOCO_SET_FSM_ID:
        return None
    try:
        return int(json.loads(event["p"])["data"])
    except (ValueError, KeyError, TypeError):
        return None


def is_damp(event: Event) -> bool:
    return fsm_of(event) == 1


def velocity_of(event: Event) -> list[float] | None:
    if event.get("api") != api_ids.LOCO_SET_VELOCITY:
        return None
    return list(json.loads(event["p"])["velocity"])


#: A request's identity id read as a send stamp must lie within this many seconds before its receipt.
_PLAUSIBLE_TRANSIT_S = 60.0


def sent_at(event: Event) -> float:
    """When the client built a request the robot received (a ``req`` event), on the record's clock.

    Unitree's Python SDK writes ``time.monotonic_ns()`` into a request's identity id as it builds it, so a request
    that reached the robot late because the robot's receiving side was starved still shows when the node sent
    it. Without a plausible stamp (another client's ids), its receive time: late, never early."""
    received = float(event["t"])
    if not isinstance(stamp := event.get("id"), int) or stamp <= 0:
        return received
    sent = stamp / 1e9
    return sent if 0.0 <= received - sent <= _PLAUSIBLE_TRANSIT_S else received


def of_kind(events: Iterable[Event], kind: str) -> list[Event]:
    return [e for e in events if e["k"] == kind]


def states(events: Iterable[Event]) -> list[Event]:
    return [e for e in events if e["k"] == "state"]


def damped(state: Event) -> bool:
    """The robot damping with a high-level service selected."""
    return state["fsm"] == 1 and bool(state["svc"])


def confirming_damp(events: Iterable[Event]) -> Event | None:
    """The Damp of a stop's damping sequence among ``events`` (those since the stop began): the second Damp, the
    first being the stop's DampNoReply. That one goes out before the forward gate closes (an e-stop) or while a
    write the gate let through before the stop may still be on its way (a FAULT, or an e-stop whose registration
    did not wait for a stalled relay); the sequence sends its Damp only once every such write is done, so from
    this Damp on nothing the stop let through can still reach the robot. The first Damp if there is only one."""
    damps = [e for e in requests(events) if is_damp(e)]
    return damps[1] if len(damps) > 1 else (damps[0] if damps else None)
