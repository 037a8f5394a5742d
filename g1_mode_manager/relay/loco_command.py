"""~/loco_command: when a verb of the built-in controller may reach the robot, and the sending of it.

ROS-free: the node serves the request, this decides and sends; the verbs themselves are core/loco_verbs.py.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Protocol

from g1_mode_manager.core import modes
from g1_mode_manager.core.loco_verbs import LOCO_VERBS
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotError, RobotPort
from g1_mode_manager.protocol.fsm import FsmMode

#: LocoCommand code of a command refused here, before anything was sent to the robot.
NOT_SENT = -1


@dataclass(frozen=True)
class LocoResult:
    success: bool
    message: str
    code: int = NOT_SENT


class LocoGate(Protocol):
    """What a loco command asks of the mode machine (see ModeMachine.robot_call)."""

    @property
    def mode(self) -> Mode: ...
    def robot_call(self, allowed: Callable[[Mode], bool]) -> AbstractContextManager[bool]: ...


def _damp_allowed(mode: Mode) -> bool:
    return mode not in (Mode.UNINITIALIZED, Mode.LOW_LEVEL)


def run_loco_command(port: RobotPort, gate: LocoGate, command: str, value: int) -> LocoResult:
    """Check the command against the mode and the robot's state, then send it.

    Damping is allowed wherever the sport service can answer (every connected mode but LOW_LEVEL);
    everything else only in HIGH_LEVEL (with no transition in flight) and only while the robot is
    static (fsm_mode 0), as the robot itself would refuse most switches while dynamic. The mode check
    and the send are one ``robot_call``: an e-stop that begins meanwhile refuses it, or waits for it to
    land and then re-damps.
    """
    mode = gate.mode
    name = command.strip().lower()
    verb = LOCO_VERBS.get(name)
    if verb is None:
        return LocoResult(False, f"unknown command {command!r}; valid: {', '.join(LOCO_VERBS)}")
    r = verb.values
    if r is not None and value not in r:
        return LocoResult(False, f"{name} takes a value from {r.start} to {r.stop - 1}, got {value}")
    if name == "damp":
        if mode is Mode.UNINITIALIZED:
            return LocoResult(False, "not connected to the robot yet (UNINITIALIZED): use ~/estop or set a mode first")
        if mode is Mode.LOW_LEVEL:
            return LocoResult(False, "LOW_LEVEL: the sport service is released, damping is impossible; use ~/estop, "
                                     "which re-selects the service and then damps")
    else:
        if not modes.allows_loco_commands(mode):
            return _not_allowed(mode)
        state = port.sport_state()
        if state is None:
            return LocoResult(False, "no rt/sportmodestate received: the robot's state is unknown")
        if state.fsm_mode == FsmMode.DYNAMIC:
            return LocoResult(False, "the robot is dynamic (fsm_mode 1): only damp is allowed; stop it first")
    with gate.robot_call(_damp_allowed if name == "damp" else modes.allows_loco_commands) as allowed:
        if not allowed:
            return _not_allowed(gate.mode)
        try:
            verb.send(port, value)
        except RobotError as exc:
            return LocoResult(False, str(exc), exc.code)
    return LocoResult(True, f"{name} sent" + (f" (value {value})" if r is not None else ""), 0)


def _not_allowed(mode: Mode) -> LocoResult:
    return LocoResult(False, f"mode is {mode.name}: loco commands are allowed only in HIGH_LEVEL "
                             "(not during a transition, an e-stop or a robot/mode mismatch)")
