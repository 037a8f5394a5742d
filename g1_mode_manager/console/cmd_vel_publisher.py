"""The fixed-rate loop that publishes cmd_vel while a page drives, and nothing otherwise.

A thread of its own, not the web server's event loop: a burst of page messages or a slow client never delays
a tick, and a tick never waits for anything but the decision (Teleop.tick) and the publish.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from g1_mode_manager.console.teleop import Teleop, Velocity


class CmdVelPublisher:
    def __init__(self, teleop: Teleop, rate_hz: float, blocked: Callable[[float], str | None],
                 publish: Callable[[Velocity], bool], clock: Callable[[], float] = time.monotonic) -> None:
        self._teleop = teleop
        self._period_s = 1.0 / rate_hz
        self._blocked = blocked
        self._publish = publish
        self._clock = clock
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._last: tuple[Velocity, float] | None = None
        self._thread = threading.Thread(target=self._run, name="cmd_vel_publisher", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(2.0)

    def step(self) -> Velocity | None:
        """One tick: publish the driving page's velocity, or nothing."""
        now = self._clock()
        v = self._teleop.tick(now, self._blocked(now))
        if v is not None and self._publish(v):
            with self._lock:
                self._last = (v, now)
            return v
        return None

    def commanded(self, now: float) -> Velocity | None:
        """What was last published, if it was published within the last two ticks (for the plots)."""
        with self._lock:
            last = self._last
        return None if last is None or now - last[1] > 2 * self._period_s else last[0]

    def _run(self) -> None:
        next_at = self._clock()
        while True:
            next_at += self._period_s
            delay = next_at - self._clock()
            if delay < 0:  # behind (a stalled process): no burst of catch-up ticks
                next_at, delay = self._clock(), 0.0
            if self._stop.wait(delay):
                return
            self.step()
