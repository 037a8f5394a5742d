"""A fixed-rate loop, for the streams that tests and benchmarks publish (a user's joint controller, a teleop flood)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


def run_at_rate(rate_hz: float, step: Callable[[], bool | None], stop: threading.Event) -> None:
    """Call ``step`` every ``1 / rate_hz`` s until ``stop`` is set or ``step`` returns False.

    A call that comes late starts the schedule afresh instead of bursting to catch up: a stream stalled by a loaded
    machine resumes at its rate, as a real controller would."""
    period = 1.0 / rate_hz
    next_at = time.monotonic()
    while not stop.is_set():
        if step() is False:
            return
        next_at += period
        delay = next_at - time.monotonic()
        if delay > 0:
            stop.wait(delay)
        else:
            next_at = time.monotonic()
