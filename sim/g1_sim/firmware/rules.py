"""The built-in controller's switching rules as data: which fsm id may follow which, and when.

Pure Python (no physics), so the table can be read in one screen and unit-tested fast. Decisions made
where the robot's behaviour is not documented:

* 802 (run on newer 29-dof firmware) is accepted wherever 801 is and walks like it.
* A robot lying on the floor gets up only through 702 (lie-to-stand), and only from damping (the vendor's
  remote instructions: damp, then lie-to-stand). 702 with the robot not lying, and 4 or 706 with it lying,
  answer 0 and leave the robot as it is (what a G1 does there is not documented: the least a client gets).
* 706 from a standing fsm squats the robot down (StandUp2Squat); from damping, a squat or sit it stands the
  robot up (Squat2StandUp). In that squat only damping and zero torque are taken, 706 included (7301): the
  vendor's remote guide has the way back up from it go through damping (after returning to the squat from main
  motion control with L2+A, back to it only through L2+B, then L2+A: the guide's note as quoted in
  phanthymotus-driver PR #215).
* Squat (2) and sit (3) are reached from standing (or from each other), not from damping.
* Requesting the current fsm id again is accepted and changes nothing (but for 706 in its squat, above).
"""

from __future__ import annotations

from typing import Final

from g1_mode_manager.protocol.api_ids import ERR_INVALID_FSM_ID, ERR_REFUSED_IN_STATE, OK
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, VALID_FSM_IDS, WALKING_FSM_IDS, FsmId
from g1_sim.firmware.posture import Posture

_ANY: Final = VALID_FSM_IDS
_STAND_ORIGINS: Final = frozenset({FsmId.DAMP, FsmId.SQUAT, FsmId.SIT}) | STANDING_FSM_IDS
_POSTURE_ORIGINS: Final = frozenset({FsmId.SQUAT, FsmId.SIT}) | STANDING_FSM_IDS

#: requested fsm id -> fsm ids it may be entered from (while the robot is static). Damp is special:
#: it is always allowed, even while dynamic.
ALLOWED_FROM: Final[dict[int, frozenset[int]]] = {
    FsmId.ZERO_TORQUE: _ANY,
    FsmId.DAMP: _ANY,
    FsmId.SQUAT: _POSTURE_ORIGINS,
    FsmId.SIT: _POSTURE_ORIGINS,
    FsmId.STAND_UP: _STAND_ORIGINS,  # StandUp needs a Damp first: never straight from zero torque
    FsmId.LIE_TO_STAND: frozenset({FsmId.DAMP}),  # from the floor, after a damp
    FsmId.SQUAT_TO_STAND: _STAND_ORIGINS,
    **{w: STANDING_FSM_IDS for w in WALKING_FSM_IDS},  # walking starts from a balanced stand
}

#: fsm ids served by the stand-up motion and then the balance (policy) controller.
STAND_UP_IDS: Final = frozenset({FsmId.STAND_UP, FsmId.LIE_TO_STAND, FsmId.SQUAT_TO_STAND})


def set_fsm_verdict(current: int, requested: int, *, dynamic: bool, squatting: bool = False) -> int:
    """Return code of SetFsmId(requested) in state ``current``: 0, 7302 (unknown id) or 7301 (refused).
    ``squatting``: the robot squats in 706 (StandUp2Squat), where only damping and zero torque are taken."""
    if requested not in VALID_FSM_IDS:
        return ERR_INVALID_FSM_ID
    if requested == FsmId.DAMP:
        return OK
    if dynamic:
        return ERR_REFUSED_IN_STATE
    if squatting:  # before the same-id case: 706 again does not stand the squat up
        return OK if requested == FsmId.ZERO_TORQUE else ERR_REFUSED_IN_STATE
    if requested == current:
        return OK
    return OK if current in ALLOWED_FROM[requested] else ERR_REFUSED_IN_STATE


def stays_as_it_is(requested: int, posture: Posture) -> bool:
    """An accepted SetFsmId that moves nothing: a stand-up (4, 706) of a lying robot, a lie-to-stand (702) of
    one that does not lie. The fsm stays where it was."""
    if requested in (FsmId.STAND_UP, FsmId.SQUAT_TO_STAND):
        return posture.lying
    if requested == FsmId.LIE_TO_STAND:
        return not posture.lying
    return False


def squats_down(current: int, requested: int) -> bool:
    """706 from a standing fsm is StandUp2Squat; from damping, squat or sit it is Squat2StandUp."""
    return requested == FsmId.SQUAT_TO_STAND and current in STANDING_FSM_IDS


def set_velocity_verdict(current: int) -> int:
    """Velocities act only in the walking fsm ids."""
    return OK if current in WALKING_FSM_IDS else ERR_REFUSED_IN_STATE


def is_dynamic(current: int, *, moving_command: bool, speed_mps: float, yaw_rate: float,
               transition_running: bool) -> bool:
    """fsm_mode 1: a posture transition is running, or the robot walks with a command or still moves fast."""
    if transition_running:
        return True
    if current in WALKING_FSM_IDS:
        return moving_command or speed_mps > DYNAMIC_SPEED_MPS or abs(yaw_rate) > DYNAMIC_YAW_RATE
    return False


#: Above these the robot counts as moving even with a zero command (it is still stopping).
DYNAMIC_SPEED_MPS: Final = 0.2
DYNAMIC_YAW_RATE: Final = 0.3


#: Held together on the operator's remote while a high-level service is active, they make the built-in
#: controller Damp. Unitree's Go2 guide gives L2+B for damping and G1 users report the same on the G1's
#: remote; not verified from a Unitree G1 document. In debug mode the controller ignores the remote.
REMOTE_DAMP_KEYS: Final = frozenset({"L2", "B"})


def remote_requests_damp(held: frozenset[str]) -> bool:
    """The keys held on the remote make the damping combination."""
    return held >= REMOTE_DAMP_KEYS
