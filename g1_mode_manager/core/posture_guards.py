"""Which posture verbs the robot's body allows, as the vendor's flows give them.

Unitree's remote-control instructions (quoted and checked on a G1 in phanthymotus-driver PR #215): powered on
folded in a squat -> damp -> squat-to-stand (706); powered on lying flat -> damp -> lie-to-stand (702); and
"after returning to the squat from main motion control, getting back up needs damp first, then 706". A stand-up
(4) or squat-to-stand does not lift a lying robot, and 706 squats a standing one down: the posture
(core/posture.py) and rt/sportmodestate's fsm decide, and a verb that cannot do what it says is refused here
with a message, before anything is sent.
"""

from __future__ import annotations

from typing import Final

from g1_mode_manager.core.posture import Posture, PostureReading
from g1_mode_manager.protocol.fsm import FsmId

#: The verbs that stand up a robot on its feet, which a lying robot does not get up with.
_FEET_STAND_UPS: Final = frozenset({"stand_up", "squat_to_stand"})
#: The verbs judged on the posture the robot reaches, which need it read before they are sent.
POSTURE_VERBS: Final = frozenset({"stand_up", "squat", "sit", "squat_to_stand", "stand_to_squat", "lie_to_stand"})
LIE_TO_STAND: Final = "lie_to_stand"
#: How a refusal of lie_to_stand begins when the robot is not lying (yet: a damped robot takes a moment to fall).
NOT_LYING: Final = "the robot is not lying"
#: The vendor's way up from the squat that 706 left: how that refusal ends.
DAMP_THEN_SQUAT_TO_STAND: Final = "damp first, then squat_to_stand"


def posture_refusal(verb: str, fsm_id: int, reading: PostureReading) -> str | None:
    """Why ``verb`` must not be sent with the robot in ``fsm_id`` and ``reading``, or None when it may be."""
    if verb not in POSTURE_VERBS:
        return None
    if reading.tilt_rad is None:
        return (f"{verb} is answered on the posture the robot reaches, and the robot's posture is unknown "
                "(no state sample from rt/lowstate or rt/lf/lowstate)")
    posture = reading.posture
    if verb in _FEET_STAND_UPS and posture.lying:
        return f"the robot lies on the floor ({reading.describe()}): damp, then lie_to_stand"
    if verb == "squat_to_stand" and fsm_id == FsmId.SQUAT_TO_STAND and posture is Posture.SQUATTING:
        return (f"the robot squats where 706 left it (fsm {fsm_id}, {reading.describe()}); the vendor's way up from "
                f"there: {DAMP_THEN_SQUAT_TO_STAND}")
    if verb == "stand_to_squat" and posture is not Posture.STANDING:
        return (f"stand_to_squat squats a standing robot down, and the robot is {reading.describe()}: 706 squats "
                "only a standing robot (it stands any other up)")
    if verb != LIE_TO_STAND:
        return None
    if fsm_id != FsmId.DAMP:
        return (f"lie_to_stand gets a damped robot up from the floor, and the robot shows fsm {fsm_id}: "
                "damp first")
    if not posture.lying:
        return (f"{NOT_LYING} ({reading.describe()}): lie_to_stand gets a robot up from the floor; on its feet "
                "use stand_up or squat_to_stand")
    return None
