"""The rt/arm_sdk blend weight: ramped in and out, never jumping (a jump makes the robot lurch)."""

from __future__ import annotations

import math


class ArmWeightRamp:
    """Moves the weight toward 1 while arm commands may pass, toward 0 otherwise, at 1/ramp_time_s per second."""

    def __init__(self, ramp_time_s: float) -> None:
        if not (math.isfinite(ramp_time_s) and ramp_time_s > 0.0):
            raise ValueError(f"arm ramp time must be finite and > 0, got {ramp_time_s}")
        self._rate = 1.0 / ramp_time_s
        self._weight = 0.0

    @property
    def weight(self) -> float:
        return self._weight

    def step(self, engage: bool, dt_s: float) -> float:
        target = 1.0 if engage else 0.0
        delta = self._rate * max(0.0, dt_s)
        self._weight += max(-delta, min(delta, target - self._weight))
        return self._weight

    def active(self) -> bool:
        """Frames must still be sent (the weight is not yet back at zero)."""
        return self._weight > 0.0
