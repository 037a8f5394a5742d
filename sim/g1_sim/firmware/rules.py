"""The built-in controller's switching rules as data: which fsm id may follow which, and when.

Pure Python (no physics), so the table can be read in one screen and unit-tested fast. Decisions made
where the robot's behaviour is not documented:

* 802 (run on newer 29-dof firmware) is accepted wherever 801 is and walks like it.
* 702 (lie-to-stand) and 706 (squat-to-stand) stand the robot up like 4 and take the same origins.
* Squat (2) and sit (3) are reached from standing (or from each other), not from damping.
* Requesting the current fsm id again is accepted and changes nothing.
"""

from __future__ import annotations

from typing import Final

from g1_mode_manager.protocol.api_ids import ERR_INVALID_FSM_ID, ERR_REFUSED_IN_STATE, OK
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, VALID_FSM_IDS, WALKING_FSM_IDS, FsmId

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
    FsmId.LIE_TO_STAND: _STAND_ORIGINS,
    FsmId.SQUAT_TO_STAND: _STAND_ORIGINS,
    **{w: STANDING_FSM_IDS for w in WALKING_FSM_IDS},  # walking starts from a balanced stand
}

#: fsm ids served by the stand-up motion and then the balance (policy) controller.
STAND_UP_IDS: Final = frozenset({FsmId.STAND_UP, FsmId.LIE_TO_STAND, FsmId.SQUAT_TO_STAND})


def set_fsm_verdict(current: int, requested: int, *, dynamic: bool) -> int:
    """Return code of SetFsmId(requested) in state ``current``: 0, 7302 (unknown id) or 7301 (refused)."""
    if requested not in VALID_FSM_IDS:
        return ERR_INVALID_FSM_ID
    if requested == FsmId.DAMP:
        return OK
    if dynamic:
        return ERR_REFUSED_IN_STATE
    if requested == current:
        return OK
    return OK if current in ALLOWED_FROM[requested] else ERR_REFUSED_IN_STATE


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
