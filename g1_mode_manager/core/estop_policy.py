"""Timing of the e-stop and of the supervision that keeps the robot damped (parameters, in seconds)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EstopTiming:
    """How long the e-stop and its supervision may wait for the robot.

    An e-stop answers within ``total_s`` plus one call timeout, whatever the robot does: with a dead
    link that is the documented bound of a failed e-stop. Its own calls use timeouts of their own
    (``call_s`` for Damp and GetFsmId, ``select_s`` for the motion switcher's CheckMode and
    SelectMode('ai') and its confirmation), never the transitions' long ones.
    """

    call_s: float = 0.5
    select_s: float = 5.0
    total_s: float = 10.0
    #: Longest wait for a relay that is in the middle of one send before the e-stop registers anyway.
    forward_wait_s: float = 0.05
    #: Pause between two attempts of an e-stop sequence that did not verify.
    retry_interval_s: float = 0.05
    #: In EMERGENCY: how often CheckMode + GetFsmId re-verify the robot even if rt/sportmodestate says fsm 1.
    verify_period_s: float = 1.0
    #: Outside EMERGENCY: how often CheckMode confirms that the robot still matches the mode.
    belief_period_s: float = 1.0
    #: rt/sportmodestate older than this is no evidence of the robot's fsm.
    state_fresh_s: float = 0.5

    def __post_init__(self) -> None:
        for name in ("call_s", "select_s", "total_s", "verify_period_s", "belief_period_s", "state_fresh_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"EstopTiming.{name} must be > 0, got {getattr(self, name)!r}")
        if self.forward_wait_s < 0 or self.retry_interval_s < 0:
            raise ValueError("EstopTiming waits must be >= 0")
