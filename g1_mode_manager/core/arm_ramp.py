"""The rt/arm_sdk blend weight: ramped in and out, never jumping (a jump makes the robot lurch)."""

from __future__ import annotations

import math

from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, WALKING_FSM_IDS, FsmMode


def robot_accepts_arm_sdk(fsm_id: int, fsm_mode: int) -> bool:
    """The built-in controller blends arm_sdk only while it stands or walks.

    A stand-up id (4, 702, 706) in fsm_mode dynamic is still running its stand-up motion: not yet.
    Walking ids are dynamic whenever they walk, and arm_sdk works then too.
    """
    if fsm_id in WALKING_FSM_IDS:
        return True
    return fsm_id in STANDING_FSM_IDS and fsm_mode == FsmMode.STATIC


class ArmWeightRamp:
    """The weight last sent, moved toward 1 (engage) or 0 at 1/ramp_time_s per second.

    ``propose`` computes the next weight, ``commit`` records it once the frame was written. ``dt`` is
    clamped to the nominal frame period: a stall ramps slower, never jumps.
    """

    def __init__(self, ramp_time_s: float, period_s: float = math.inf) -> None:
        if not (math.isfinite(ramp_time_s) and ramp_time_s > 0.0):
            raise ValueError(f"arm ramp time must be finite and > 0, got {ramp_time_s}")
        if not period_s > 0.0:
            raise ValueError(f"arm frame period must be > 0, got {period_s}")
        self._rate = 1.0 / ramp_time_s
        self._period_s = period_s
        self._weight = 0.0

    @property
    def weight(self) -> float:
        return self._weight

    @property
    def max_step(self) -> float:
        """The largest change of one frame."""
        return self._rate * self._period_s

    def propose(self, engage: bool, dt_s: float) -> float:
        target = 1.0 if engage else 0.0
        delta = self._rate * min(max(0.0, dt_s), self._period_s)
        return self._weight + max(-delta, min(delta, target - self._weight))

    def commit(self, weight: float) -> None:
        self._weight = weight

    def restart(self) -> None:
        """The robot dropped the blend (it stopped standing): the next ramp starts from 0."""
        self._weight = 0.0

    def step(self, engage: bool, dt_s: float) -> float:
        """propose + commit."""
        self._weight = self.propose(engage, dt_s)
        return self._weight

    def active(self) -> bool:
        """Frames must still be sent (the weight is not yet back at zero)."""
        return self._weight > 0.0
