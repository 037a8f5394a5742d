"""Filling unitree_hg LowCmd_ frames from MotorCommands, refusing anything the robot must never get."""

from __future__ import annotations

import math
from collections.abc import Sequence

from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.idl import LowCmd_, MotorCmd_
from g1_mode_manager.protocol.motors import NUM_MOTOR_SLOTS


def new_lowcmd() -> LowCmd_:
    """An all-zero LowCmd_ (every motor disabled)."""
    motors = [MotorCmd_(mode=0, q=0.0, dq=0.0, tau=0.0, kp=0.0, kd=0.0, reserve=0) for _ in range(NUM_MOTOR_SLOTS)]
    return LowCmd_(mode_pr=0, mode_machine=0, motor_cmd=motors, reserve=[0, 0, 0, 0], crc=0)


def check_commands(frame: str, commands: Sequence[MotorCommand], expected: int) -> None:
    """ValueError unless there are ``expected`` commands, all finite, with gains >= 0 (never send NaN)."""
    if len(commands) != expected:
        raise ValueError(f"{frame}: expected {expected} motor commands, got {len(commands)}")
    for i, c in enumerate(commands):
        values = (c.q, c.dq, c.tau, c.kp, c.kd)
        if not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
            raise ValueError(f"{frame}: command {i} has a non-finite value: {c}")
        if c.kp < 0 or c.kd < 0:
            raise ValueError(f"{frame}: command {i} has a negative gain: {c}")


def fill_motor(slot: MotorCmd_, command: MotorCommand, mode: int) -> None:
    slot.mode = mode
    slot.q, slot.dq, slot.tau = float(command.q), float(command.dq), float(command.tau)
    slot.kp, slot.kd = float(command.kp), float(command.kd)
