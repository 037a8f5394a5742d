"""States (fsm ids) and modes of the G1's built-in locomotion controller."""

from enum import IntEnum
from typing import Final


class FsmId(IntEnum):
    """Values of SetFsmId / GetFsmId and SportModeState_.fsm_id."""

    ZERO_TORQUE = 0
    DAMP = 1
    SQUAT = 2
    SIT = 3
    STAND_UP = 4  # lock standing
    WALK_OLD = 200  # alias of START sent by older SDKs
    START = 500  # walk (balance stand with gait)
    START_WAIST = 501  # walk with 3-dof waist
    LIE_TO_STAND = 702
    SQUAT_TO_STAND = 706
    RUN = 801
    RUN_29DOF = 802  # run mode of newer 29-dof firmware (SetFsmId(500) is ignored there; use 501)


#: Every fsm id SetFsmId accepts; others answer 7302.
VALID_FSM_IDS: Final = frozenset(int(f) for f in FsmId)
#: States in which the controller stands or walks (arm_sdk works, velocities act where walking).
STANDING_FSM_IDS: Final = frozenset({FsmId.STAND_UP, FsmId.WALK_OLD, FsmId.START, FsmId.START_WAIST,
                                     FsmId.LIE_TO_STAND, FsmId.SQUAT_TO_STAND, FsmId.RUN, FsmId.RUN_29DOF})
WALKING_FSM_IDS: Final = frozenset({FsmId.WALK_OLD, FsmId.START, FsmId.START_WAIST, FsmId.RUN, FsmId.RUN_29DOF})


#: GetFsmId while the robot is under user control (SwitchToUserCtrl, 7110; newer firmware): its built-in
#: controller no longer drives the joints, ``rt/user_lowcmd`` does. Not a SetFsmId target.
USER_CTRL_FSM_ID: Final = 1000


class InternalCtrl(IntEnum):
    """SwitchToInternalCtrl's ``{"data": ...}``: which built-in controller takes the robot back (7111)."""

    LAST = 0  # the controller that ran before the switch
    PASSIVE = 1  # damping (fsm 1)
    WALKRUN = 2  # the walk-run controller, standing


class FsmMode(IntEnum):
    """SportModeState_.fsm_mode / GetFsmMode."""

    STATIC = 0  # switching allowed
    DYNAMIC = 1  # most switches refused; damping always allowed


class BalanceMode(IntEnum):
    """SetBalanceMode: BalanceStand = 0, ContinuousGait(True) = 1."""

    BALANCE_STAND = 0
    CONTINUOUS_GAIT = 1


#: SetSpeedMode 0..3 -> maximum forward speed in m/s.
SPEED_MODE_MAX_SPEED: Final = {0: 1.0, 1: 1.5, 2: 2.0, 3: 2.7}
