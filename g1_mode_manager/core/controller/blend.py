"""The way from the robot's measured pose to a controller's targets: a linear blend over a set time, so an engage
never steps the joints (dimos ramps for the same reason; unitree_rl_gym's deploy moves to the default pose over 2 s).
"""

from __future__ import annotations

import numpy as np

from g1_mode_manager.core.controller.interface import JointTargets


class Blend:
    """``apply(targets, elapsed_s)``: position targets moved from ``start_q`` toward the controller's by
    elapsed / duration (1 from then on); speeds and feed-forward torques scaled by the same weight, gains the
    controller's (the pose at the start is held with them)."""

    def __init__(self, start_q: np.ndarray, duration_s: float) -> None:
        if not duration_s >= 0.0:
            raise ValueError(f"blend time must be >= 0 s, got {duration_s}")
        self._start = np.asarray(start_q, dtype=float).copy()
        self._duration_s = duration_s

    def weight(self, elapsed_s: float) -> float:
        if self._duration_s == 0.0:
            return 1.0
        return float(min(1.0, max(0.0, elapsed_s / self._duration_s)))

    def apply(self, targets: JointTargets, elapsed_s: float) -> JointTargets:
        a = self.weight(elapsed_s)
        if a >= 1.0:
            return targets
        return JointTargets(q=self._start + a * (targets.q - self._start), dq=a * targets.dq, tau=a * targets.tau,
                            kp=targets.kp, kd=targets.kd)
