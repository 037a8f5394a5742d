"""Pacing of sim time against wall time, and the time stamps the bridge puts on what it publishes."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

#: If the sim falls further behind than this (s of wall time), it does not sprint to catch up.
MAX_LAG_S = 0.1
#: Sleep only when at least this far ahead (s); shorter sleeps cost more than they pace.
MIN_SLEEP_S = 0.0005


class Pacer:
    """Keeps sim time at ``speed`` x wall time (1 = real time, 0 = as fast as possible).

    ``pace(sim_time)`` sleeps until wall time catches up with sim time; a sim that cannot keep up
    simply runs slower (the reference is moved, so it never bursts to catch up afterwards).
    """

    def __init__(self, speed: float = 1.0, *, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        if speed < 0:
            raise ValueError(f"speed must be >= 0, got {speed}")
        self._clock = clock
        self._sleep = sleep
        self._lock = threading.Lock()
        self._speed = speed
        self._ref_wall: float | None = None
        self._ref_sim = 0.0

    @property
    def speed(self) -> float:
        return self._speed

    def set_speed(self, speed: float) -> None:
        """Change speed at run time; pacing restarts from the next pace() call."""
        if speed < 0:
            raise ValueError(f"speed must be >= 0, got {speed}")
        with self._lock:
            self._speed = speed
            self._ref_wall = None

    def pace(self, sim_time: float) -> None:
        with self._lock:
            speed = self._speed
            if speed == 0:
                return
            now = self._clock()
            if self._ref_wall is None:
                self._ref_wall, self._ref_sim = now, sim_time
                return
            ahead = self._ref_wall + (sim_time - self._ref_sim) / speed - now
            if ahead < -MAX_LAG_S:
                self._ref_wall, self._ref_sim = now, sim_time
                return
        if ahead >= MIN_SLEEP_S:
            self._sleep(ahead)


class RateMeter:
    """Real-time factor (sim seconds per wall second) over the last window."""

    def __init__(self, window_s: float = 2.0, *, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._window_s = window_s
        self._start_wall: float | None = None
        self._start_sim = 0.0
        self._last = 0.0
        self._total_wall = 0.0
        self._total_sim = 0.0

    def update(self, sim_time: float) -> None:
        now = self._clock()
        if self._start_wall is None:
            self._start_wall, self._start_sim = now, sim_time
            return
        wall = now - self._start_wall
        if wall >= self._window_s:
            self._last = (sim_time - self._start_sim) / wall
            self._total_wall += wall
            self._total_sim += sim_time - self._start_sim
            self._start_wall, self._start_sim = now, sim_time

    @property
    def real_time_factor(self) -> float:
        """Over the last full window (0 until one has passed)."""
        return self._last

    @property
    def mean_real_time_factor(self) -> float:
        """Over all full windows so far."""
        return self._total_sim / self._total_wall if self._total_wall > 0 else 0.0


class StampClock:
    """ROS stamps in sim time, offset to the wall time at start.

    At speed 1 the stamps stay close to wall time, so nodes that do not use /clock see fresh
    messages; at other speeds they follow sim time (and /clock carries the same time).
    """

    def __init__(self, epoch_ns: int | None = None) -> None:
        self.epoch_ns = time.time_ns() if epoch_ns is None else epoch_ns

    def stamp_ns(self, sim_time: float) -> int:
        return self.epoch_ns + round(sim_time * 1e9)
