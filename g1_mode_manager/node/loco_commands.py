"""The built-in controller's posture/locomotion commands, as reachable from ROS, and their rules."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Protocol

from g1_mode_manager.core import modes
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotError, RobotPort
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import FsmId, FsmMode

#: LocoCommand code of a command refused here, before anything was sent to the robot.
NOT_SENT = -1


@dataclass(frozen=True)
class LocoResult:
    success: bool
    message: str
    code: int = NOT_SENT


def _fsm(fsm_id: FsmId) -> Callable[[RobotPort, int], None]:
    return lambda port, _value: port.set_fsm_id(int(fsm_id))


def _speed_mode(port: RobotPort, value: int) -> None:
    port.set_speed_mode(value)


def _continuous_gait(port: RobotPort, value: int) -> None:
    port.set_balance_mode(1 if value else 0)


def _arm_task(task_id: int) -> Callable[[RobotPort, int], None]:
    return lambda port, _value: port.set_arm_task(task_id)


def _shake_hand(port: RobotPort, value: int) -> None:
    port.set_arm_task(api.ARM_TASK_SHAKE_HAND_OUT if value == 0 else api.ARM_TASK_SHAKE_HAND_BACK)


COMMANDS: dict[str, Callable[[RobotPort, int], None]] = {
    "damp": _fsm(FsmId.DAMP),
    "zero_torque": _fsm(FsmId.ZERO_TORQUE),
    "squat": _fsm(FsmId.SQUAT),
    "sit": _fsm(FsmId.SIT),
    "stand_up": _fsm(FsmId.STAND_UP),
    "start": _fsm(FsmId.START),
    "balance_stand": lambda port, _value: port.set_balance_mode(0),
    "continuous_gait": _continuous_gait,
    "speed_mode": _speed_mode,
    "high_stand": lambda port, _value: port.high_stand(),
    "low_stand": lambda port, _value: port.low_stand(),
    "wave_hand": _arm_task(api.ARM_TASK_WAVE),
    "wave_and_turn": _arm_task(api.ARM_TASK_WAVE_AND_TURN),
    "shake_hand": _shake_hand,  # value 0: hold the hand out, 1: withdraw it
}

_VALUE_RANGES = {"continuous_gait": range(0, 2), "speed_mode": range(0, 4), "shake_hand": range(0, 2)}


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
    action = COMMANDS.get(name)
    if action is None:
        return LocoResult(False, f"unknown command {command!r}; valid: {', '.join(COMMANDS)}")
    if name in _VALUE_RANGES and value not in _VALUE_RANGES[name]:
        r = _VALUE_RANGES[name]
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
            action(port, value)
        except RobotError as exc:
            return LocoResult(False, str(exc), exc.code)
    return LocoResult(True, f"{name} sent" + (f" (value {value})" if name in _VALUE_RANGES else ""), 0)


def _not_allowed(mode: Mode) -> LocoResult:
    return LocoResult(False, f"mode is {mode.name}: loco commands are allowed only in HIGH_LEVEL "
                             "(not during a transition, an e-stop or a robot/mode mismatch)")
