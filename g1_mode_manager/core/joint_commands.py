"""Validation of joint commands by Unitree joint name, before anything reaches rt/lowcmd or rt/arm_sdk."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.motors import (
    ARM_SDK_JOINT_NAMES,
    DAMPING_KD,
    EFFORT_LIMIT_NM,
    JOINT_INDEX,
    JOINT_NAMES,
    NUM_JOINTS,
)

#: Gains above these are refused: no G1 joint is stable with more (N m/rad, N m s/rad).
MAX_KP = 500.0
MAX_KD = 50.0


class JointCommandError(ValueError):
    """A joint command that must not be sent; the message says why."""


@dataclass(frozen=True)
class JointTargets:
    """Validated per-joint commands, keyed by motor index."""

    commands: dict[int, MotorCommand]


def _check_lengths(names: Sequence[str], fields: dict[str, Sequence[float]], allow_empty: set[str]) -> None:
    n = len(names)
    if n == 0:
        raise JointCommandError("no joint names given")
    for field, values in fields.items():
        if len(values) == 0 and field in allow_empty:
            continue
        if len(values) != n:
            raise JointCommandError(f"{field} has {len(values)} entries for {n} joint names")


def _check_names(names: Sequence[str], allowed: Sequence[str]) -> list[int]:
    allowed_set = set(allowed)
    unknown = [n for n in names if n not in allowed_set]
    if unknown:
        raise JointCommandError(f"unknown or not allowed joint names {unknown}; allowed: {', '.join(allowed)}")
    if len(set(names)) != len(names):
        raise JointCommandError("duplicate joint names")
    return [JOINT_INDEX[n] for n in names]


def _value(values: Sequence[float], i: int) -> float:
    return float(values[i]) if len(values) else 0.0


def validate_joint_command(
    names: Sequence[str],
    q: Sequence[float],
    dq: Sequence[float],
    tau: Sequence[float],
    kp: Sequence[float],
    kd: Sequence[float],
    *,
    allowed: Sequence[str],
) -> JointTargets:
    """Check names, lengths, finiteness, gain and torque bounds; dq and tau may be empty (zero)."""
    _check_lengths(names, {"q": q, "dq": dq, "tau": tau, "kp": kp, "kd": kd}, allow_empty={"dq", "tau"})
    indices = _check_names(names, allowed)
    commands: dict[int, MotorCommand] = {}
    for i, motor in enumerate(indices):
        cmd = MotorCommand(q=_value(q, i), dq=_value(dq, i), tau=_value(tau, i), kp=_value(kp, i), kd=_value(kd, i))
        if not all(math.isfinite(v) for v in (cmd.q, cmd.dq, cmd.tau, cmd.kp, cmd.kd)):
            raise JointCommandError(f"non-finite value for {names[i]}: {cmd}")
        if not 0.0 <= cmd.kp <= MAX_KP or not 0.0 <= cmd.kd <= MAX_KD:
            raise JointCommandError(f"gains of {names[i]} out of range (0 <= kp <= {MAX_KP}, 0 <= kd <= {MAX_KD})")
        if abs(cmd.tau) > EFFORT_LIMIT_NM[motor]:
            limit = EFFORT_LIMIT_NM[motor]
            raise JointCommandError(f"tau {cmd.tau} of {names[i]} exceeds its effort limit {limit} N m")
        commands[motor] = cmd
    return JointTargets(commands)


def validate_lowcmd(
    names: Sequence[str],
    q: Sequence[float],
    dq: Sequence[float],
    tau: Sequence[float],
    kp: Sequence[float],
    kd: Sequence[float],
) -> JointTargets:
    """Low-level commands may name any of the 29 joints."""
    return validate_joint_command(names, q, dq, tau, kp, kd, allowed=JOINT_NAMES)


def validate_arm_targets(names: Sequence[str], positions: Sequence[float]) -> dict[int, float]:
    """Arm targets (sensor_msgs/JointState positions) for the waist and arm joints of rt/arm_sdk."""
    if len(positions) != len(names):
        raise JointCommandError(f"position has {len(positions)} entries for {len(names)} joint names")
    indices = _check_names(names, ARM_SDK_JOINT_NAMES) if names else []
    if not indices:
        raise JointCommandError("no joint names given")
    out: dict[int, float] = {}
    for i, motor in enumerate(indices):
        value = float(positions[i])
        if not math.isfinite(value):
            raise JointCommandError(f"non-finite position for {names[i]}")
        out[motor] = value
    return out


def damping_frame() -> list[MotorCommand]:
    """All 29 joints soft: kp 0, kd > 0 (what silence on rt/lowcmd turns into)."""
    return [MotorCommand(kd=DAMPING_KD) for _ in range(NUM_JOINTS)]


def full_frame(targets: JointTargets) -> list[MotorCommand]:
    """29 commands in motor order: the named joints as given, the others damped."""
    frame = damping_frame()
    for motor, cmd in targets.commands.items():
        frame[motor] = cmd
    return frame
