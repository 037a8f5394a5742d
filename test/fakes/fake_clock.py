"""Fake time for the tests: the clock moves only when a test advances it or something sleeps on it,
so timeouts cost nothing and every reading is exact."""

from __future__ import annotations

import threading


class FakeClock:
    """A monotonic clock (call it for the time) that moves only by ``advance`` or ``sleep``."""

    def __init__(self, start: float = 1000.0) -> None:
        self._lock = threading.Lock()
        self._now = start
        self.slept = 0.0

    def __call__(self) -> float:
        with self._lock:
            return self._now

    def advance(self, seconds: float) -> None:
        """Time passes without anyone sleeping (a test stepping a relay, a stalled thread)."""
        with self._lock:
            self._now += seconds

    def sleep(self, seconds: float) -> None:
        """What the code under test calls instead of time.sleep: time passes at once, and is counted."""
        with self._lock:
            self._now += seconds
            self.slept += seconds
