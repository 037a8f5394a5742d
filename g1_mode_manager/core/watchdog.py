"""A command-stream watchdog: silence longer than the timeout means 'stop'."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


class Watchdog:
    """Fed on every command; `expired()` is True once no command came for `timeout_s`.

    Starts expired (nothing fed yet), so a stream must begin before anything is forwarded.
    """

    def __init__(self, timeout_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        if not timeout_s > 0.0:
            raise ValueError(f"watchdog timeout must be > 0, got {timeout_s}")
        self._timeout_s = timeout_s
        self._clock = clock
        self._last: float | None = None
        self._lock = threading.Lock()

    @property
    def timeout_s(self) -> float:
        return self._timeout_s

    def feed(self) -> None:
        with self._lock:
            self._last = self._clock()

    def reset(self) -> None:
        """Forget the stream (e.g. on leaving the mode that forwards it)."""
        with self._lock:
            self._last = None

    def age_s(self) -> float | None:
        with self._lock:
            return None if self._last is None else self._clock() - self._last

    def deadline(self) -> float | None:
        """When the stream will count as silent (clock time), or None if nothing was fed."""
        with self._lock:
            return None if self._last is None else self._last + self._timeout_s

    def expired(self) -> bool:
        age = self.age_s()
        return age is None or age > self._timeout_s
