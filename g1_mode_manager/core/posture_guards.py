"""Which posture verbs the robot's body allows: the lying robot gets up only through lie_to_stand.

A G1 on the floor gets up through damping and then lie-to-stand (702), as the vendor's remote instructions
give it; a stand-up (4) or squat-to-stand (706) does not lift it, and 702 is meant for a robot that lies.
The body watch knows the attitude (the IMU tilt), rt/sportmodestate the controller's state: a verb that
cannot do what it says is refused here with a message, before anything is sent.
"""

from __future__ import annotations

from typing import Final

from g1_mode_manager.protocol.fsm import FsmId

#: A robot tilted past this lies on the floor: the fall check's angle (terminations.hpp bad_orientation).
LYING_TILT_RAD: Final = 1.0
#: The verbs that stand up a robot on its feet, which a lying robot does not get up with.
_FEET_STAND_UPS: Final = frozenset({"stand_up", "squat_to_stand"})
LIE_TO_STAND: Final = "lie_to_stand"
#: How a refusal of lie_to_stand begins when the robot is not lying (yet: a damped robot takes a moment to fall).
NOT_LYING: Final = "the robot is not lying"


def lying(tilt_rad: float | None) -> bool:
    return tilt_rad is not None and tilt_rad > LYING_TILT_RAD


def posture_refusal(verb: str, fsm_id: int, tilt_rad: float | None) -> str | None:
    """Why ``verb`` must not be sent with the robot in ``fsm_id`` at ``tilt_rad`` (None: the attitude is not
    known), or None when it may be."""
    if verb in _FEET_STAND_UPS and lying(tilt_rad):
        return f"the robot lies on the floor (tilt {tilt_rad:.2f} rad): damp, then lie_to_stand"
    if verb != LIE_TO_STAND:
        return None
    if fsm_id != FsmId.DAMP:
        return (f"lie_to_stand gets a damped robot up from the floor, and the robot shows fsm {fsm_id}: "
                "damp first")
    if tilt_rad is None:
        return "the robot's attitude is unknown (no state sample): lie_to_stand needs to see it lying"
    if not lying(tilt_rad):
        return (f"{NOT_LYING} (tilt {tilt_rad:.2f} rad, lying is above {LYING_TILT_RAD:.1f}): "
                "lie_to_stand gets a robot up from the floor; on its feet use stand_up or squat_to_stand")
    return None
