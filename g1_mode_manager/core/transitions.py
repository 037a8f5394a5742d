"""The transition table: every legal mode change as data, and an explicit reason for every other one.

The table is the whole policy; :class:`~g1_mode_manager.core.machine.ModeMachine` only executes the
steps listed here. Same-mode requests (other than a repeated e-stop) are refused with "already in X":
a caller that needs idempotence reads the mode from the outcome. The one exception is data too:
after the robot was seen not to match the mode, requesting that mode re-runs its entry (``reentry``).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from g1_mode_manager.core.modes import Mode


class Step(Enum):
    """What a transition does to the robot, in order."""

    CONNECT = "connect"  # initialise the SDK connection (only the first transition)
    ENSURE_SERVICE_ACTIVE = "ensure_service_active"  # CheckMode; SelectMode("ai") only if released; confirm
    RELEASE_SERVICE = "release_service"  # ReleaseMode until CheckMode reports "" (official low-level entry)
    ESTOP = "estop"  # DampNoReply, ensure the service is active, Damp (see ModeMachine.estop)
    PROTECTIVE_STOP = "protective_stop"  # a body check tripped: the e-stop's damping path, into FAULT
    # the user_ctrl path (core/user_ctrl.py): the robot is held by a controller throughout
    USER_CTRL = "user_ctrl"  # hand-over frame, SwitchToUserCtrl, GetFsmId 1000 seen
    HAND_BACK_LAST = "hand_back_last"  # SwitchToInternalCtrl(LAST), then another fsm seen
    HAND_BACK_WALKRUN = "hand_back_walkrun"  # upright: SwitchToInternalCtrl(WALKRUN), a standing fsm seen


class Trigger(Enum):
    """Who may cause a transition: an operator's request, the body supervision, or clear_fault."""

    REQUEST = "request"  # set_mode (and the e-stop, which every mode allows)
    BODY_CHECK = "body_check"  # a body check's fault reaction
    CLEAR_FAULT = "clear_fault"  # an operator's explicit clear, once every check is clear
    SILENCE = "silence"  # ~/lowcmd silent on the user_ctrl path: the robot handed back to its own controller


@dataclass(frozen=True)
class Transition:
    """One legal (source, target) pair, the robot steps it takes and what it means for the operator."""

    source: Mode
    target: Mode
    steps: tuple[Step, ...]
    description: str
    #: The robot is limp afterwards even if no SelectMode was needed (it was released before): the
    #: outcome says so (ZERO_TORQUE_NOTE), as it does after every SelectMode.
    leaves_robot_limp: bool = False
    trigger: Trigger = Trigger.REQUEST


#: Added to a transition's outcome when the robot comes out of it limp: SelectMode brings the service back
#: in zero torque, as at boot.
ZERO_TORQUE_NOTE = "robot is in zero torque; send stand_up/damp"


_U, _I, _H, _L, _E, _F = Mode.UNINITIALIZED, Mode.IDLE, Mode.HIGH_LEVEL, Mode.LOW_LEVEL, Mode.EMERGENCY, Mode.FAULT
_BODY, _CLEAR = Trigger.BODY_CHECK, Trigger.CLEAR_FAULT
_CONNECT, _ACTIVE, _RELEASE = Step.CONNECT, Step.ENSURE_SERVICE_ACTIVE, Step.RELEASE_SERVICE

TRANSITIONS: tuple[Transition, ...] = (
    Transition(_U, _I, (_CONNECT,),          "connected; nothing is forwarded"),
    Transition(_U, _H, (_CONNECT, _ACTIVE),  "connected; high-level service active"),
    Transition(_U, _L, (_CONNECT, _RELEASE), "connected; high-level service released, robot limp"),
    Transition(_I, _H, (_ACTIVE,),           "high-level service active"),
    Transition(_I, _L, (_RELEASE,),          "high-level service released, robot limp"),
    Transition(_H, _I, (),                   "forwarding stopped (the node sends StopMove)"),
    Transition(_H, _L, (_RELEASE,),          "high-level service released, robot limp"),
    Transition(_L, _I, (),                   "forwarding stopped; robot stays released (limp, debug mode)"),
    Transition(_L, _H, (_ACTIVE,),           "high-level service active", leaves_robot_limp=True),
    *(Transition(m, _E, (Step.ESTOP,),       "e-stop: damping") for m in Mode),
    *(Transition(m, _F, (Step.PROTECTIVE_STOP,), "protective stop: damping", trigger=_BODY) for m in (_I, _H, _L)),
    Transition(_F, _I, (),                   "fault cleared: nothing is forwarded; the robot stays damped",
               trigger=_CLEAR),
)

TABLE: dict[tuple[Mode, Mode], Transition] = {(t.source, t.target): t for t in TRANSITIONS}

_USER, _LAST, _WALKRUN = Step.USER_CTRL, Step.HAND_BACK_LAST, Step.HAND_BACK_WALKRUN
_SILENCE = Trigger.SILENCE

#: low_level_path user_ctrl: the rules with LOW_LEVEL at either end, instead of the release path's.
USER_CTRL_TRANSITIONS: tuple[Transition, ...] = (
    Transition(_U, _L, (_CONNECT, _USER), "robot under user control (fsm 1000 seen); ~/lowcmd -> rt/user_lowcmd"),
    Transition(_I, _L, (_USER,),          "robot under user control (fsm 1000 seen); ~/lowcmd -> rt/user_lowcmd"),
    Transition(_H, _L, (_USER,),          "robot under user control (fsm 1000 seen); ~/lowcmd -> rt/user_lowcmd"),
    Transition(_L, _I, (_LAST,),          "robot handed back to the controller it had before; nothing is forwarded"),
    Transition(_L, _H, (_WALKRUN,),       "robot handed back to its walk-run controller, standing"),
)
USER_CTRL_SILENCE = Transition(_L, _I, (_WALKRUN,), "~/lowcmd silent: robot handed back to its walk-run controller, "
                               "standing; nothing is forwarded", trigger=_SILENCE)
USER_CTRL_TABLE: dict[tuple[Mode, Mode], Transition] = {**TABLE, **{(t.source, t.target): t
                                                                   for t in USER_CTRL_TRANSITIONS}}

#: Requesting the current mode after a robot/mode mismatch re-runs the mode's entry, as from IDLE.
REENTRIES: dict[Mode, Transition] = {
    _I: Transition(_I, _I, (),         "re-entered: nothing is forwarded"),
    _H: Transition(_H, _H, (_ACTIVE,),  "high-level service active"),
    _L: Transition(_L, _L, (_RELEASE,), "high-level service released, robot limp"),
}
USER_CTRL_REENTRY = Transition(_L, _L, (_USER,), "robot under user control again (fsm 1000 seen)")


def lookup(source: Mode, target: Mode, trigger: Trigger = Trigger.REQUEST, *,
           user_ctrl: bool = False) -> Transition | str:
    """The legal transition from source to target for this trigger, or the reason it is refused.

    ``user_ctrl``: the low_level_path user_ctrl's rules for LOW_LEVEL. Every (source, target, trigger) is either
    in the table or matched by an explicit refusal below; one matched by neither is a bug in this module and
    raises AssertionError.
    """
    if user_ctrl and (source, target, trigger) == (_L, _I, _SILENCE):
        return USER_CTRL_SILENCE
    legal = (USER_CTRL_TABLE if user_ctrl else TABLE).get((source, target))
    if legal is not None and legal.trigger is trigger:
        return legal
    match (source, target, trigger):
        case (Mode.EMERGENCY, _, _):
            return "nothing leaves EMERGENCY: make the robot safe, then restart the mode manager"
        case (_, Mode.FAULT, Trigger.REQUEST):
            return "FAULT is entered when a body check trips, not requested"
        case (Mode.FAULT, _, Trigger.REQUEST):
            return "in FAULT: clear it with ~/clear_fault (to IDLE) once every check is clear, or e-stop"
        case (Mode.FAULT, Mode.FAULT, Trigger.BODY_CHECK):
            return "already in FAULT; the new fault is added to the list"
        case (_, _, Trigger.CLEAR_FAULT):
            return f"not in FAULT ({source.name}): no fault to clear"
        case (Mode.UNINITIALIZED, _, Trigger.BODY_CHECK):
            return "not connected yet: no body check acts before the first transition"
        case (_, _, Trigger.BODY_CHECK):
            return f"a body check enters FAULT only, not {target.name}"
        case (Mode.LOW_LEVEL, Mode.IDLE, Trigger.SILENCE):
            return "a silent ~/lowcmd hands the robot back only on low_level_path user_ctrl"
        case (_, _, Trigger.SILENCE):
            return f"a silent ~/lowcmd hands the robot back from LOW_LEVEL to IDLE only, not {source.name} -> {target.name}"
        case (s, t, _) if s is t:
            return f"already in {s.name}; nothing to do"
        case (_, Mode.UNINITIALIZED, _):
            return "nothing goes back to UNINITIALIZED; request IDLE to stop forwarding"
    raise AssertionError(f"transition table has no rule for {source.name} -> {target.name} by {trigger.value}")


def rule_for(source: Mode, target: Mode, *, mismatch: bool, trigger: Trigger = Trigger.REQUEST,
             user_ctrl: bool = False) -> Transition | str:
    """``lookup``, except that after a robot/mode mismatch the current mode's entry runs again."""
    if mismatch and source is target and source in REENTRIES and trigger is Trigger.REQUEST:
        return USER_CTRL_REENTRY if user_ctrl and source is Mode.LOW_LEVEL else REENTRIES[source]
    return lookup(source, target, trigger, user_ctrl=user_ctrl)
