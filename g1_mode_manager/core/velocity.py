"""cmd_vel safety: reject non-finite input, clamp each axis, limit acceleration."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Velocity:
    """A body velocity command: vx, vy in m/s, wz in rad/s."""

    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0

    def is_zero(self) -> bool:
        return self.vx == 0.0 and self.vy == 0.0 and self.wz == 0.0


ZERO = Velocity()


@dataclass(frozen=True)
class VelocityLimits:
    """Per-axis magnitude limits (m/s, m/s, rad/s) and acceleration limits (m/s^2, m/s^2, rad/s^2)."""

    max_vx: float = 0.8
    max_vy: float = 0.4
    max_wz: float = 1.0
    max_ax: float = 1.5
    max_ay: float = 1.0
    max_aw: float = 3.0

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"velocity limit {name} must be finite and > 0, got {value}")


@dataclass(frozen=True)
class Sanitized:
    """The command that may be sent, and what was done to it."""

    velocity: Velocity
    rejected: bool  # non-finite input: replaced by zero
    clamped: bool  # at least one axis was over its limit
    reason: str = ""


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


def sanitize(vx: float, vy: float, wz: float, limits: VelocityLimits) -> Sanitized:
    """Non-finite input becomes zero (rejected); each axis is clamped to its limit."""
    values = (vx, vy, wz)
    if not all(math.isfinite(v) for v in values):
        return Sanitized(ZERO, rejected=True, clamped=False, reason=f"non-finite cmd_vel {values}")
    clamped = Velocity(_clamp(vx, limits.max_vx), _clamp(vy, limits.max_vy), _clamp(wz, limits.max_wz))
    was_clamped = (clamped.vx, clamped.vy, clamped.wz) != values
    reason = f"cmd_vel {values} clamped to {(clamped.vx, clamped.vy, clamped.wz)}" if was_clamped else ""
    return Sanitized(clamped, rejected=False, clamped=was_clamped, reason=reason)


class RateLimiter:
    """Moves the sent velocity toward the target by at most the acceleration limit per step."""

    def __init__(self, limits: VelocityLimits) -> None:
        self._limits = limits
        self._current = ZERO

    @property
    def current(self) -> Velocity:
        return self._current

    def reset(self) -> None:
        """After a StopMove the robot is commanded to zero: start again from there."""
        self._current = ZERO

    def step(self, target: Velocity, dt_s: float) -> Velocity:
        if not (math.isfinite(dt_s) and dt_s >= 0.0):
            raise ValueError(f"dt must be finite and >= 0, got {dt_s}")
        lim = self._limits

        def toward(cur: float, tgt: float, accel: float) -> float:
            step = accel * dt_s
            return cur + max(-step, min(step, tgt - cur))

        self._current = Velocity(
            toward(self._current.vx, target.vx, lim.max_ax),
            toward(self._current.vy, target.vy, lim.max_ay),
            toward(self._current.wz, target.wz, lim.max_aw),
        )
        return self._current
