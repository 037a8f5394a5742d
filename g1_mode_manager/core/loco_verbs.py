"""The verbs of ~/loco_command: each one's name, what it does on the robot port and which values it takes.

The one table of them: the service's rules (relay/loco_command.py) look verbs up here, and the numbers
sent are the protocol's constants (FsmId, BalanceMode, ARM_TASK_*), the same the SDK's LocoClient sends.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Final

from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import SPEED_MODE_MAX_SPEED, BalanceMode, FsmId

#: The values of a verb that takes a flag: 0 (off) or 1 (on).
FLAG: Final = range(2)


@dataclass(frozen=True)
class LocoVerb:
    """``send(port, value)`` makes the verb's robot call; ``values`` is None for a verb that ignores its value."""

    send: Callable[[RobotPort, int], None]
    values: range | None = None


def _fsm(fsm_id: FsmId) -> LocoVerb:
    return LocoVerb(lambda port, _value: port.set_fsm_id(int(fsm_id)))


def _balance(port: RobotPort, continuous: int) -> None:
    port.set_balance_mode(int(BalanceMode.CONTINUOUS_GAIT if continuous else BalanceMode.BALANCE_STAND))


def _arm_task(task_id: int) -> LocoVerb:
    return LocoVerb(lambda port, _value: port.set_arm_task(task_id))


LOCO_VERBS: Final[Mapping[str, LocoVerb]] = {
    "damp": _fsm(FsmId.DAMP),
    "zero_torque": _fsm(FsmId.ZERO_TORQUE),
    "squat": _fsm(FsmId.SQUAT),
    "sit": _fsm(FsmId.SIT),
    "stand_up": _fsm(FsmId.STAND_UP),
    "start": _fsm(FsmId.START),
    "balance_stand": LocoVerb(lambda port, _value: _balance(port, 0)),
    "continuous_gait": LocoVerb(_balance, FLAG),
    "speed_mode": LocoVerb(lambda port, value: port.set_speed_mode(value), range(len(SPEED_MODE_MAX_SPEED))),
    "high_stand": LocoVerb(lambda port, _value: port.high_stand()),
    "low_stand": LocoVerb(lambda port, _value: port.low_stand()),
    "wave_hand": _arm_task(api.ARM_TASK_WAVE),
    "wave_and_turn": _arm_task(api.ARM_TASK_WAVE_AND_TURN),
    # value 0: hold the hand out, 1: withdraw it
    "shake_hand": LocoVerb(lambda port, stage: port.set_arm_task(api.ARM_TASK_SHAKE_HAND_STAGES[stage]),
                           range(len(api.ARM_TASK_SHAKE_HAND_STAGES))),
}
