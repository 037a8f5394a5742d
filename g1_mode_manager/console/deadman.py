"""The dead-man of one page: it may drive only while it is visible, focused, holds a key or the stick, and its
heartbeat is fresh. Anything else lets go at once, and says why.

Pure: the server feeds it each ``teleop`` message with the time it arrived, and the publisher asks it at each
tick. A page that goes quiet (a hidden tab's throttled timers, a frozen browser, a cut network) is caught by the
deadline even when its last message still said "visible, W held".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from g1_mode_manager.console.messages import Teleop

Axes = tuple[float, float, float]


@dataclass
class DeadMan:
    deadline_s: float
    _last: Teleop | None = None
    _heard_at: float = -math.inf
    _open: bool = True

    def __post_init__(self) -> None:
        if not self.deadline_s > 0:
            raise ValueError("heartbeat_deadline_s must be > 0")

    def heard(self, msg: Teleop, now: float) -> None:
        self._last, self._heard_at = msg, now

    def close(self) -> None:
        """The socket is gone: nothing of this page drives again."""
        self._open = False

    def why_not(self, now: float) -> str | None:
        """Why this page may not drive now (the first reason that holds), or None if it may."""
        if not self._open:
            return "socket closed"
        if self._last is None:
            return "no heartbeat yet"
        age = now - self._heard_at
        if age > self.deadline_s:
            return f"heartbeat late ({age * 1000:.0f} ms > {self.deadline_s * 1000:.0f} ms)"
        if not self._last.visible:
            return "page hidden"
        if not self._last.focused:
            return "window not focused"
        if not self._last.held:
            return "no key or stick held"
        return None

    def wants(self, now: float) -> bool:
        """The page asks to drive: alive and holding something (visibility aside), for the driver lock."""
        return self._open and self._last is not None and self._last.held and now - self._heard_at <= self.deadline_s

    def axes(self, now: float) -> Axes | None:
        """The held axes (-1..1 each) while the dead-man is satisfied, else None."""
        if self.why_not(now) is not None:
            return None
        assert self._last is not None
        return (self._last.vx, self._last.vy, self._last.wz)
