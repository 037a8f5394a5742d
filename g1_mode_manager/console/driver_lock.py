"""One console drives at a time: the first that asks while nobody drives holds the lock; it keeps it while it
drives and for ``idle_release_s`` after (so a tap on a key does not hand the robot to another page between two
taps); a closed socket releases it at once. The others are told who holds it."""

from __future__ import annotations


class DriverLock:
    def __init__(self, idle_release_s: float) -> None:
        if idle_release_s < 0:
            raise ValueError("driver_release_s must be >= 0")
        self._idle_release_s = float(idle_release_s)
        self._holder: str | None = None
        self._active_at = 0.0

    def holder(self, now: float) -> str | None:
        if self._holder is not None and now - self._active_at > self._idle_release_s:
            self._holder = None
        return self._holder

    def claim(self, who: str, now: float) -> bool:
        """``who`` drives now: True if it holds (or now takes) the lock, False if another holds it."""
        holder = self.holder(now)
        if holder is not None and holder != who:
            return False
        self._holder, self._active_at = who, now
        return True

    def release(self, who: str) -> None:
        if self._holder == who:
            self._holder = None
