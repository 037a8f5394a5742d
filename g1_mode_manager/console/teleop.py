"""Teleop across every open page: which page drives (the driver lock), whether its dead-man holds, and the
cmd_vel to publish at this tick, or nothing.

The publisher asks :meth:`Teleop.tick` at a fixed rate; the server feeds it each page's messages. Nothing here
ever publishes a velocity by itself: a page that lets go makes the tick return None, the console stops
publishing, and the mode manager's own watchdog stops the robot (cmd_vel_timeout_s), exactly as for any other
cmd_vel publisher that goes silent.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

from g1_mode_manager.console.deadman import DeadMan
from g1_mode_manager.console.driver_lock import DriverLock
from g1_mode_manager.console.messages import Teleop as TeleopMsg

Velocity = tuple[float, float, float]


@dataclass(frozen=True)
class Limits:
    """Full stick or key = this velocity (m/s, m/s, rad/s); the mode manager clamps again with its own."""

    max_vx: float
    max_vy: float
    max_wz: float

    def __post_init__(self) -> None:
        for name in ("max_vx", "max_vy", "max_wz"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0")

    def scale(self, axes: Velocity) -> Velocity:
        return (axes[0] * self.max_vx, axes[1] * self.max_vy, axes[2] * self.max_wz)


@dataclass(frozen=True)
class TeleopStatus:
    """What one page is told: who drives, whether its own commands are published now, and if not, why."""

    driver: str | None
    you_drive: bool
    publishing: bool
    why_not: str | None


class Teleop:
    def __init__(self, deadline_s: float, release_s: float, limits: Limits) -> None:
        self._deadline_s = deadline_s
        self._limits = limits
        self._lock = threading.Lock()
        self._pages: dict[str, DeadMan] = {}  # in the order they joined: the first to hold a key drives
        self._labels: dict[str, str] = {}
        self._driver = DriverLock(release_s)
        self._publishing: str | None = None

    def join(self, page: str, label: str) -> None:
        with self._lock:
            self._pages[page] = DeadMan(self._deadline_s)
            self._labels[page] = label

    def leave(self, page: str) -> None:
        with self._lock:
            dead_man = self._pages.pop(page, None)
            if dead_man is not None:
                dead_man.close()
            self._labels.pop(page, None)
            self._driver.release(page)
            if self._publishing == page:
                self._publishing = None

    def heard(self, page: str, msg: TeleopMsg, now: float) -> None:
        with self._lock:
            dead_man = self._pages.get(page)
            if dead_man is not None:
                dead_man.heard(msg, now)

    def tick(self, now: float, blocked: str | None = None) -> Velocity | None:
        """The cmd_vel to publish now, or None. ``blocked``: why nobody may drive now (e.g. not HIGH_LEVEL)."""
        with self._lock:
            self._publishing = None
            if blocked is not None:
                return None
            holder = self._driver.holder(now)
            if holder is None:
                holder = next((p for p, d in self._pages.items() if d.axes(now) is not None), None)
            if holder is None:
                return None
            axes = self._pages[holder].axes(now)
            if axes is None:
                return None
            self._driver.claim(holder, now)
            self._publishing = holder
            return self._limits.scale(axes)

    def status(self, page: str, now: float, blocked: str | None = None) -> TeleopStatus:
        with self._lock:
            holder = self._driver.holder(now)
            driver = None if holder is None else self._labels.get(holder)
            dead_man = self._pages.get(page)
            why = "not connected" if dead_man is None else dead_man.why_not(now)
            if why is None and blocked is not None:
                why = blocked
            if why is None and holder is not None and holder != page:
                why = f"{driver} drives"
            return TeleopStatus(driver, holder == page, self._publishing == page, why)

    def driving(self) -> str | None:
        """The label of the page whose command was published at the last tick."""
        with self._lock:
            return None if self._publishing is None else self._labels.get(self._publishing)
