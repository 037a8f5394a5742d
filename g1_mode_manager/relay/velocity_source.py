"""One source of velocity commands for the Move stream: its limits, latest command, watchdog and ramp.

The teleop (/cmd_vel) and the autonomy (cmd_vel_nav) each have one, so each is held to its own velocity and
acceleration limits and its own silence timeout; the cmd_vel relay sends from whichever drives (core/drive.py).
"""

from __future__ import annotations

from collections.abc import Callable

from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.velocity import ZERO, AccelerationLimiter, Sanitized, Velocity, VelocityLimits, sanitize
from g1_mode_manager.core.watchdog import Watchdog


class VelocitySource:
    """``target`` and ``untaken`` are guarded by the relay's lock; ``limiter`` is the sender thread's."""

    def __init__(self, driver: Driver, topic: str, limits: VelocityLimits, timeout_s: float, ramp_s: float,
                 clock: Callable[[], float]) -> None:
        self.driver = driver
        self.topic = topic  # names the source in log lines and answers
        self.key = "cmd_vel" if driver is Driver.TELEOP else "autonomy"  # names its counters
        self.limits = limits
        self.watchdog = Watchdog(timeout_s, clock)
        self.limiter = AccelerationLimiter(limits, max_dt_s=ramp_s)
        self.target = ZERO
        self.untaken = 0  # commands taken since the sender's last step (dropped if the gate refuses)

    def sanitize(self, vx: float, vy: float, wz: float) -> Sanitized:
        return sanitize(vx, vy, wz, self.limits)

    def take(self, v: Velocity) -> bool:
        """The source's newest command; True if the sender should look now (a change, or a restart after
        silence: a repeat of a running command is the keep-alive tick's business)."""
        changed = v != self.target
        self.target = v
        self.untaken += 1
        restarted = self.watchdog.expired()
        self.watchdog.feed()
        return changed or restarted

    def forget(self) -> None:
        """No command from this source stands any more (its driver changed, or forwarding stopped)."""
        self.target = ZERO
        self.watchdog.reset()
