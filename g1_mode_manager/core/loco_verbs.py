"""The verbs of ~/loco_command: each one's name, what it does on the robot port, which values it takes and
what the robot must show afterwards for the command to count as done.

The one table of them: the service's rules (relay/loco_command.py) look verbs up here, and the numbers
sent are the protocol's constants (FsmId, BalanceMode, ARM_TASK_*), the same the SDK's LocoClient sends.
A return code of 0 is not an outcome (firmware 1.5.3 answers 0 to Start and does nothing from some
states), so every verb names the state it is judged by (relay/loco_outcome.py reads it). A posture verb is
judged on the posture the robot reaches too (core/posture.py), and one whose outcome holds already is not sent.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Final

from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.core.posture import Posture
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import SPEED_MODE_MAX_SPEED, BalanceMode, FsmId, FsmMode

#: The values of a verb that takes a flag: 0 (off) or 1 (on).
FLAG: Final = range(2)


@dataclass(frozen=True)
class FsmShown:
    """rt/sportmodestate shows ``fsm_id``. ``motion``: the verb starts a posture motion of seconds (stand up,
    squat, sit): done once it stopped (fsm_mode 0), judged against the longer motion timeout. ``get_up``: the
    motion is a get-up from the floor, judged against the get-up timeout (longer still). ``posture``: the
    posture the robot must be in besides. ``any_fsm``: the verb asks for the posture alone (706 and 702 get the
    robot into it), so a robot already in it under another fsm needs nothing sent: 706 would even reverse it."""

    fsm_id: int
    motion: bool = False
    get_up: bool = False
    posture: Posture | None = None
    any_fsm: bool = False

    def reached(self, fsm_id: int, fsm_mode: int, posture: Posture) -> bool:
        """The outcome, as the robot shows it after the send: the fsm (its motion over, for a motion) and the
        posture. Another fsm id is entered as soon as it shows: start while the robot still steps shows fsm 500
        with fsm_mode 1, and that is its outcome."""
        return (fsm_id == self.fsm_id and (fsm_mode == FsmMode.STATIC or not self.motion)
                and (self.posture is None or posture is self.posture))

    def already(self, fsm_id: int, fsm_mode: int, posture: Posture) -> bool:
        """The outcome holds before anything is sent: only for a posture verb, and with the robot at rest."""
        if self.posture is None or posture is not self.posture or fsm_mode != FsmMode.STATIC:
            return False
        return self.any_fsm or fsm_id == self.fsm_id


@dataclass(frozen=True)
class BalanceShown:
    """GetBalanceMode answers ``mode``."""

    mode: int


@dataclass(frozen=True)
class StandHeightShown:
    """GetStandHeight moved up (``highest``) or down from its value before the command, or already sits at the
    extreme a verified command of the same verb left it at (the robot's range is not documented)."""

    highest: bool


@dataclass(frozen=True)
class TaskShown:
    """rt/sportmodestate shows ``task_id`` playing with a task_time that began after the command was sent."""

    task_id: int


@dataclass(frozen=True)
class NotReadable:
    """The robot has no way to be asked: the command is answered on its return code, and says so."""

    why: str


Expected = FsmShown | BalanceShown | StandHeightShown | TaskShown | NotReadable


@dataclass(frozen=True)
class LocoVerb:
    """``send(port, value)`` makes the verb's robot call; ``expect(value)`` is what the robot must show after
    it; ``values`` is None for a verb that ignores its value."""

    send: Callable[[RobotPort, int], None]
    expect: Callable[[int], Expected]
    values: range | None = None


def _fsm(fsm_id: FsmId, *, motion: bool = False, get_up: bool = False, posture: Posture | None = None,
         any_fsm: bool = False) -> LocoVerb:
    shown = FsmShown(int(fsm_id), motion or get_up, get_up, posture, any_fsm)
    return LocoVerb(lambda port, _value: port.set_fsm_id(int(fsm_id)), lambda _value: shown)


def _balance_mode(continuous: int) -> int:
    return int(BalanceMode.CONTINUOUS_GAIT if continuous else BalanceMode.BALANCE_STAND)


def _balance(port: RobotPort, continuous: int) -> None:
    port.set_balance_mode(_balance_mode(continuous))


def _arm_task(task_id: int) -> LocoVerb:
    return LocoVerb(lambda port, _value: port.set_arm_task(task_id), lambda _value: TaskShown(task_id))


def _shake_hand_task(stage: int) -> int:
    return api.ARM_TASK_SHAKE_HAND_STAGES[stage]


LOCO_VERBS: Final[Mapping[str, LocoVerb]] = {
    "damp": _fsm(FsmId.DAMP),
    "zero_torque": _fsm(FsmId.ZERO_TORQUE),
    "squat": _fsm(FsmId.SQUAT, motion=True, posture=Posture.SQUATTING),
    "sit": _fsm(FsmId.SIT, motion=True, posture=Posture.SITTING),
    "stand_up": _fsm(FsmId.STAND_UP, motion=True, posture=Posture.STANDING),
    # Unitree's Lie2StandUp: from damping, the robot lying on the floor (guarded: core/posture_guards.py)
    "lie_to_stand": _fsm(FsmId.LIE_TO_STAND, get_up=True, posture=Posture.STANDING, any_fsm=True),
    # Squat2StandUp and StandUp2Squat send the same id: the robot's posture decides which way it goes
    "squat_to_stand": _fsm(FsmId.SQUAT_TO_STAND, motion=True, posture=Posture.STANDING, any_fsm=True),
    "stand_to_squat": _fsm(FsmId.SQUAT_TO_STAND, motion=True, posture=Posture.SQUATTING, any_fsm=True),
    "start": _fsm(FsmId.START),
    "balance_stand": LocoVerb(lambda port, _value: _balance(port, 0), lambda _value: BalanceShown(_balance_mode(0))),
    "continuous_gait": LocoVerb(_balance, lambda value: BalanceShown(_balance_mode(value)), FLAG),
    "speed_mode": LocoVerb(lambda port, value: port.set_speed_mode(value),
                           lambda _value: NotReadable("the robot has no getter for its speed mode"),
                           range(len(SPEED_MODE_MAX_SPEED))),
    "high_stand": LocoVerb(lambda port, _value: port.high_stand(), lambda _value: StandHeightShown(highest=True)),
    "low_stand": LocoVerb(lambda port, _value: port.low_stand(), lambda _value: StandHeightShown(highest=False)),
    "wave_hand": _arm_task(api.ARM_TASK_WAVE),
    "wave_and_turn": _arm_task(api.ARM_TASK_WAVE_AND_TURN),
    # value 0: hold the hand out, 1: withdraw it
    "shake_hand": LocoVerb(lambda port, stage: port.set_arm_task(_shake_hand_task(stage)),
                           lambda stage: TaskShown(_shake_hand_task(stage)),
                           range(len(api.ARM_TASK_SHAKE_HAND_STAGES))),
}
