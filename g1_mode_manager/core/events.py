"""How workers report (the relays, the body watch, the head LED display): counters and throttled log lines,
without depending on ROS logging."""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Callable

LogFn = Callable[[str, str], None]  # (level: "info" | "warn" | "error", text)


class RelayEvents:
    """Thread-safe counters plus a log function throttled per key (at most once per period)."""

    def __init__(self, log: LogFn, throttle_s: float = 2.0, clock: Callable[[], float] = time.monotonic) -> None:
        self._log = log
        self._throttle_s = throttle_s
        self._clock = clock
        self._counts: Counter[str] = Counter()
        self._last_logged: dict[str, float] = {}
        self._lock = threading.Lock()

    def count(self, key: str, n: int = 1) -> None:
        with self._lock:
            self._counts[key] += n

    def counts(self) -> dict[str, int]:
        with self._lock:
            return dict(self._counts)

    def log(self, level: str, key: str, text: str) -> None:
        """Log `text` unless the same key was logged less than the throttle period ago."""
        now = self._clock()
        with self._lock:
            last = self._last_logged.get(key)
            if last is not None and now - last < self._throttle_s:
                return
            self._last_logged[key] = now
        self._log(level, text)
