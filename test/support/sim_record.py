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


class SimRecord:
    """The events of one bridge's record file, re-read on every call (the bridge appends while we read)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def events(self, since: float = float("-inf")) -> list[Event]:
        if not self.path.exists():
            return []
        out = []
        with self.path.open() as f:
            for line in f:
                if not line.endswith("\n"):
                    break  # a line still being written
                event = json.loads(line)
                if event["t"] >= since:
                    out.append(event)
        return out

    def after_last_reset(self) -> list[Event]:
        events = self.events()
        resets = [i for i, e in enumerate(events) if e["k"] == "reset"]
        return events[resets[-1] + 1 :] if resets else events


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


def states(events: Iterable[Event]) -> list[Event]:
    return [e for e in events if e["k"] == "state"]


def damped(state: Event) -> bool:
    """The robot damping with a high-level service selected."""
    return state["fsm"] == 1 and bool(state["svc"])
