"""User control (newer firmware): SwitchToUserCtrl (sport 7110) hands the joints to ``rt/user_lowcmd`` with the
robot standing; SwitchToInternalCtrl (7111) gives them back to a built-in controller.

Pure Python (no physics): the firmware option, the preconditions of 7110, where 7111 returns, and the phase
of a switch. :mod:`~g1_sim.firmware.user_ctrl_service` answers the calls with it, and
:mod:`~g1_sim.firmware.handover` hands the joints over.

Vendor sources (unitree_sdk2 ``g1_loco_api.hpp`` / ``g1_userctrl_dds_example.cpp``, unitree-app-templates
``g1_mimic_demo/deploy_template``) and user reports disagree or are silent on most of it; where they are, the
sim takes the reading that gives a client the least (docs/robot_compat.md, "User control", marks each one
**unverified on a real G1**):

* The option says which precondition a firmware has: ``from_damp`` (the SDK example: fsm 1 only),
  ``from_walkrun`` (the app template: the walk-run controller standing or walking, stand-up motion finished),
  ``either``, or ``none`` (older firmware: both apis answer 3203).
* A refused 7110 answers 7301 (the sim's "refused in this state"; no vendor source names a code), also while
  a switch is already pending or in force: the client must read GetFsmId, never infer it from a code.
* The switch takes effect ``delay_s`` of sim time after 7110 is accepted (a user read the old fsm, 801, right
  after the call; the template waits 0.1 s before it checks 1000). Until then the built-in controller still
  drives the joints and GetFsmId shows the old fsm, but the switch is committed: SetFsmId and Move already
  answer 0 and do nothing, 7111 answers 0 and does not cancel it.
* WALKRUN returns to fsm 801 (the walk-run fsm a user read on a G1 around the switch); LAST to the fsm the
  robot had before 7110 (1, or the standing/walking fsm it was in).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Final

from g1_mode_manager.protocol.api_ids import ERR_REFUSED_IN_STATE, ERR_SERVER_API_NOT_IMPL, OK
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, FsmId, InternalCtrl


class UserCtrlOption(enum.StrEnum):
    """Which firmware the sim plays: where SwitchToUserCtrl is accepted, or not at all."""

    NONE = "none"
    FROM_DAMP = "from_damp"
    FROM_WALKRUN = "from_walkrun"
    EITHER = "either"


DEFAULT_OPTION: Final = UserCtrlOption.EITHER
#: Sim time from an accepted 7110 to fsm 1000 and user frames applied, s.
DEFAULT_DELAY_S: Final = 0.05
#: Largest delay a configuration may set, s (a test of a slow firmware, not a hang).
MAX_DELAY_S: Final = 10.0
#: What 7110 answers when refused (not a vendor code: none is documented).
REFUSAL_CODE: Final = ERR_REFUSED_IN_STATE
#: The fsm SwitchToInternalCtrl(WALKRUN) returns to.
WALKRUN_FSM: Final = int(FsmId.RUN)


class Phase(enum.Enum):
    INTERNAL = "internal"  # a built-in controller drives the joints
    SWITCHING = "switching"  # 7110 accepted, the delay not over: the built-in controller still drives
    USER = "user"  # fsm 1000: the joints follow rt/user_lowcmd


def parse_option(value: str) -> UserCtrlOption:
    """The option named ``value``; ValueError naming the choices otherwise."""
    try:
        return UserCtrlOption(value)
    except ValueError:
        raise ValueError(f"user_ctrl must be one of {[o.value for o in UserCtrlOption]}, got {value!r}") from None


def check_delay(delay_s: float) -> float:
    if isinstance(delay_s, bool) or not isinstance(delay_s, int | float) or not 0.0 <= delay_s <= MAX_DELAY_S:
        raise ValueError(f"user_ctrl_delay_s must be a number of seconds within 0..{MAX_DELAY_S:g}, got {delay_s!r}")
    return float(delay_s)


def switch_in_verdict(option: UserCtrlOption, fsm: int, *, balanced: bool, phase: Phase) -> int:
    """SwitchToUserCtrl's code in fsm ``fsm`` (``balanced``: the walk-run controller stands or walks on its own,
    no stand-up motion running)."""
    if option is UserCtrlOption.NONE:
        return ERR_SERVER_API_NOT_IMPL
    if phase is not Phase.INTERNAL:
        return REFUSAL_CODE
    from_damp = fsm == FsmId.DAMP
    from_walkrun = fsm in STANDING_FSM_IDS and balanced
    match option:
        case UserCtrlOption.FROM_DAMP:
            accepted = from_damp
        case UserCtrlOption.FROM_WALKRUN:
            accepted = from_walkrun
        case UserCtrlOption.EITHER:
            accepted = from_damp or from_walkrun
    return OK if accepted else REFUSAL_CODE


def internal_target(target: InternalCtrl, before: int) -> int:
    """The fsm SwitchToInternalCtrl(target) takes the robot to, ``before`` being its fsm before 7110."""
    match target:
        case InternalCtrl.LAST:
            return before
        case InternalCtrl.PASSIVE:
            return int(FsmId.DAMP)
        case InternalCtrl.WALKRUN:
            return WALKRUN_FSM


@dataclass
class UserCtrl:
    """The switch's state: the option, the delay, the phase, when it takes effect and the fsm it left."""

    option: UserCtrlOption = DEFAULT_OPTION
    delay_s: float = DEFAULT_DELAY_S
    phase: Phase = Phase.INTERNAL
    starts_at: float = math.inf  # sim time at which a pending switch takes effect
    before: int = int(FsmId.DAMP)  # the fsm before 7110

    @property
    def engaged(self) -> bool:
        """A switch is pending or in force: SetFsmId and Move do nothing."""
        return self.phase is not Phase.INTERNAL

    @property
    def active(self) -> bool:
        return self.phase is Phase.USER

    def begin(self, now: float, fsm: int) -> None:
        self.phase, self.starts_at, self.before = Phase.SWITCHING, now + self.delay_s, int(fsm)

    def due(self, now: float) -> bool:
        """The pending switch takes effect now."""
        return self.phase is Phase.SWITCHING and now >= self.starts_at

    def activate(self) -> None:
        self.phase, self.starts_at = Phase.USER, math.inf

    def end(self) -> None:
        self.phase, self.starts_at = Phase.INTERNAL, math.inf
