"""cmd_vel safety: reject non-finite input, clamp each axis, limit acceleration, bound the Move lease."""

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

#: The real G1's Move ignores velocities below about this (m/s and rad/s, per axis): a command whose
#: every axis is below it does not walk the robot, so the relay sends a StopMove instead, once.
MOVE_DEAD_BAND = 0.1

#: Longest Move lease (s): a node that dies lets the robot stop by itself within this time.
MAX_MOVE_DURATION_S = 2.0


def in_dead_band(v: Velocity, band: float = MOVE_DEAD_BAND) -> bool:
    """True if the robot would ignore this command on every axis."""
    return abs(v.vx) < band and abs(v.vy) < band and abs(v.wz) < band


def check_move_duration(duration_s: float) -> float:
    """A Move lease must be finite, > 0 and at most MAX_MOVE_DURATION_S (continuous mode is refused)."""
    if not (math.isfinite(duration_s) and 0.0 < duration_s <= MAX_MOVE_DURATION_S):
        raise ValueError(f"move duration must be in (0, {MAX_MOVE_DURATION_S}] s so the robot stops by itself "
                         f"if the node dies, got {duration_s}")
    return duration_s


@dataclass(frozen=True)
class VelocityLimits:
    """Per-axis magnitude limits (m/s, m/s, rad/s) and acceleration limits (m/s^2, m/s^2, rad/s^2).

    No defaults: the node's parameters (node/settings.py) are the one place they are chosen.
    """

    max_vx: float
    max_vy: float
    max_wz: float
    max_ax: float
    max_ay: float
    max_awz: float

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


class AccelerationLimiter:
    """Moves the commanded velocity toward the target by at most the acceleration limit per step.

    ``propose`` computes the next command without changing state; ``commit`` records it once the
    robot acknowledged it, so refused or lost Moves never advance the ramp. ``dt`` is clamped to
    ``max_dt_s``: a stalled caller ramps slower, never in one jump.
    """

    def __init__(self, limits: VelocityLimits, max_dt_s: float = math.inf) -> None:
        if not max_dt_s > 0.0:
            raise ValueError(f"max_dt_s must be > 0, got {max_dt_s}")
        self._limits = limits
        self._max_dt_s = max_dt_s
        self._current = ZERO

    @property
    def current(self) -> Velocity:
        """The last committed command (what the robot acknowledged)."""
        return self._current

    def reset(self, start: Velocity = ZERO) -> None:
        """Start again from ``start`` (the robot's velocity, or zero when unknown)."""
        self._current = start

    def propose(self, target: Velocity, dt_s: float) -> Velocity:
        if not (math.isfinite(dt_s) and dt_s >= 0.0):
            raise ValueError(f"dt must be finite and >= 0, got {dt_s}")
        dt_s = min(dt_s, self._max_dt_s)
        lim = self._limits

        def toward(cur: float, tgt: float, accel: float) -> float:
            step = accel * dt_s
            return cur + max(-step, min(step, tgt - cur))

        return Velocity(
            toward(self._current.vx, target.vx, lim.max_ax),
            toward(self._current.vy, target.vy, lim.max_ay),
            toward(self._current.wz, target.wz, lim.max_awz),
        )

    def commit(self, sent: Velocity) -> None:
        self._current = sent

    def step(self, target: Velocity, dt_s: float) -> Velocity:
        """propose + commit, for callers whose every step reaches the robot."""
        self._current = self.propose(target, dt_s)
        return self._current
