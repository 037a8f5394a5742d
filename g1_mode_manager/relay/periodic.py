"""A worker thread that calls a step function at a fixed rate, with the real elapsed time."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


class PeriodicWorker:
    """Runs `step(dt_s)` every 1/rate_hz seconds until stopped; a slow step delays, never queues."""

    def __init__(self, name: str, rate_hz: float, step: Callable[[float], None],
                 on_error: Callable[[BaseException], None] | None = None) -> None:
        if not rate_hz > 0.0:
            raise ValueError(f"{name}: rate must be > 0 Hz, got {rate_hz}")
        self._period = 1.0 / rate_hz
        self._step = step
        self._on_error = on_error
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout_s: float = 3.0) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def _run(self) -> None:
        last = time.monotonic()
        next_tick = last + self._period
        while not self._stop.wait(max(0.0, next_tick - time.monotonic())):
            now = time.monotonic()
            try:
                self._step(now - last)
            except Exception as exc:  # a relay bug must not kill the worker silently
                if self._on_error is not None:
                    self._on_error(exc)
            last = now
            next_tick = max(next_tick + self._period, time.monotonic())
