"""A worker thread that calls a step function at a fixed rate, with the real elapsed time.

With a ``busy`` predicate it sleeps without a timeout while there is nothing to do (its stream cannot
pass, nothing to ramp or damp) and runs again when woken: an idle node wakes no thread 50 times a second.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


class PeriodicWorker:
    """Runs `step(dt_s)` every 1/rate_hz seconds until stopped; a slow step delays, never queues.

    ``busy()`` (optional) is asked before every step: while it is False the worker waits for ``wake()``.
    Whoever makes it True must call ``wake()`` (a new command, a mode change); the first step after a
    wake gets the nominal dt, not the idle time.
    """

    def __init__(self, name: str, rate_hz: float, step: Callable[[float], None],
                 on_error: Callable[[BaseException], None] | None = None,
                 busy: Callable[[], bool] | None = None,
                 period_s: Callable[[], float] | None = None) -> None:
        """``period_s`` (optional) is asked after every step for the time to the next one (a worker whose
        rate follows its input's), instead of 1 / rate_hz."""
        if not rate_hz > 0.0:
            raise ValueError(f"{name}: rate must be > 0 Hz, got {rate_hz}")
        self._period = 1.0 / rate_hz
        self._period_of = period_s
        self._step = step
        self._on_error = on_error
        self._busy = busy
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def wake(self) -> None:
        """Ask ``busy()`` again now (cheap when the worker is running anyway)."""
        self._wake.set()

    def stop(self, timeout_s: float = 3.0) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def _idle(self) -> bool:
        try:
            return self._busy is not None and not self._busy()
        except Exception as exc:  # a faulty predicate must not stop the worker: then it just keeps its rate
            if self._on_error is not None:
                self._on_error(exc)
            return False

    def _run(self) -> None:
        last = time.monotonic()
        next_tick = last + self._period
        while not self._stop.is_set():
            if self._idle():
                self._wake.wait()
                self._wake.clear()
                now = time.monotonic()
                last, next_tick = now - self._period, now
                continue
            if self._stop.wait(max(0.0, next_tick - time.monotonic())):
                break
            now = time.monotonic()
            try:
                self._step(now - last)
            except Exception as exc:  # a relay bug must not kill the worker silently
                if self._on_error is not None:
                    self._on_error(exc)
            last = now
            if self._period_of is not None:
                self._period = self._period_of()
            next_tick = max(next_tick + self._period, time.monotonic())
