"""Validation of joint commands by Unitree joint name, before anything reaches rt/lowcmd or rt/arm_sdk."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from functools import lru_cache
from math import isfinite
from operator import le
from typing import Any

import numpy as np

from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.motors import (
    ARM_SDK_JOINT_NAMES,
    DAMPING_KD,
    EFFORT_LIMIT_NM,
    JOINT_INDEX,
    JOINT_NAMES,
    JOINT_RANGE_RAD,
    NUM_JOINTS,
)

#: Gains above these are refused: no G1 joint is stable with more (N m/rad, N m s/rad).
MAX_KP = 500.0
MAX_KD = 50.0
#: A position target may lie this far outside its joint's range (rad): a PD target past the stop is how a policy
#: presses a joint against it (holosoma's walker sets an ankle 0.14 rad past its range while it stands, and no
#: field deploy clips its targets), the torque it costs is kp times the excess and capped by the motor; a target
#: of 100 rad is a bug.
RANGE_MARGIN_RAD = 0.5
#: The robot's frames hold float32: a larger finite dq would reach it as infinity.
MAX_ABS_DQ = float(np.finfo(np.float32).max)


class JointCommandError(ValueError):
    """A joint command that must not be sent; the message says why."""


@dataclass(frozen=True, slots=True)
class JointFrame(Sequence[MotorCommand]):
    """All 29 joints' commands, in motor order: the named ones (their motor ``indices`` and one column per
    field, in the same order) as given, every other joint damped (kp 0, kd DAMPING_KD).

    Held as columns so that a 500 Hz relay packs it without a MotorCommand per joint; indexing gives
    MotorCommands for whoever wants them. ``block``, when the frame was checked from one (``validate_joint_block``),
    is the five columns as one 5 x n float64 array (the columns are its rows): a writer packs it in one step.
    """

    indices: tuple[int, ...]
    q: Sequence[float]
    dq: Sequence[float]
    tau: Sequence[float]
    kp: Sequence[float]
    kd: Sequence[float]
    block: Any = dataclass_field(default=None, compare=False, repr=False)

    def __len__(self) -> int:
        return NUM_JOINTS

    def __getitem__(self, motor: int) -> MotorCommand:  # type: ignore[override]
        if not -NUM_JOINTS <= motor < NUM_JOINTS:
            raise IndexError(motor)
        motor %= NUM_JOINTS
        if motor not in self.indices:
            return _DAMPED
        k = self.indices.index(motor)
        return MotorCommand(q=self.q[k], dq=self.dq[k], tau=self.tau[k], kp=self.kp[k], kd=self.kd[k])

    @property
    def damping(self) -> bool:
        """Every joint damped (no joint named)."""
        return not self.indices

    @staticmethod
    def of(commands: Sequence[MotorCommand]) -> JointFrame:
        """29 MotorCommands (motor order) as a frame naming every joint."""
        if len(commands) != NUM_JOINTS:
            raise JointCommandError(f"expected {NUM_JOINTS} motor commands, got {len(commands)}")
        return JointFrame(tuple(range(NUM_JOINTS)), *(tuple(float(getattr(c, f)) for c in commands)
                                                      for f in ("q", "dq", "tau", "kp", "kd")))


_DAMPED = MotorCommand(kd=DAMPING_KD)
#: Every joint soft: kp 0, kd > 0 (what silence on rt/lowcmd turns into).
DAMPING = JointFrame((), (), (), (), (), ())


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


@lru_cache(maxsize=64)
def _indices(names: tuple[str, ...], allowed: tuple[str, ...]) -> tuple[tuple[int, ...], tuple[float, ...],
                                                                      tuple[float, ...], tuple[float, ...]]:
    """(motor indices, effort limits, lowest and highest position targets) of a list of names; checked once per
    distinct list (a controller sends the same names every time). Raises JointCommandError (and caches nothing)
    for a bad list."""
    indices = tuple(_check_names(names, allowed))
    return (indices, tuple(EFFORT_LIMIT_NM[i] for i in indices),
            tuple(JOINT_RANGE_RAD[i][0] - RANGE_MARGIN_RAD for i in indices),
            tuple(JOINT_RANGE_RAD[i][1] + RANGE_MARGIN_RAD for i in indices))


def _column(values: Sequence[float], n: int) -> tuple[float, ...]:
    return tuple(map(float, values)) if len(values) else (0.0,) * n


def _within(values: tuple[float, ...], high: float) -> bool:
    return all(map(isfinite, values)) and min(values) >= 0.0 and max(values) <= high


def validate_joint_command(
    names: Sequence[str],
    q: Sequence[float],
    dq: Sequence[float],
    tau: Sequence[float],
    kp: Sequence[float],
    kd: Sequence[float],
    *,
    allowed: Sequence[str],
) -> JointFrame:
    """Check names, lengths, finiteness, position ranges, gain and torque bounds; dq and tau may be empty (zero).

    Whole columns are checked at once (C builtins over tuples: cheap enough for every message of a 500 Hz
    stream); only a refused command is looked at joint by joint, to say which joint and why.
    """
    n = len(names)
    if n and len(q) == n and len(kp) == n and len(kd) == n and len(dq) in (0, n) and len(tau) in (0, n):
        indices, limits, lows, highs = _indices(tuple(names), tuple(allowed))
        cols = (_column(q, n), _column(dq, n), _column(tau, n), _column(kp, n), _column(kd, n))
        qc, dqc, tauc, kpc, kdc = cols
        if (all(map(isfinite, qc)) and all(map(isfinite, dqc)) and max(map(abs, dqc)) <= MAX_ABS_DQ
                and all(map(isfinite, tauc))
                and all(map(le, lows, qc)) and all(map(le, qc, highs))
                and _within(kpc, MAX_KP) and _within(kdc, MAX_KD) and all(map(le, map(abs, tauc), limits))):
            return JointFrame(indices, *cols)
    _explain(names, q, dq, tau, kp, kd, allowed)
    raise JointCommandError("joint command refused")  # the explanation always raises; never forward on doubt


@lru_cache(maxsize=64)
def _block_bounds(names: tuple[str, ...], allowed: tuple[str, ...]) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
    """(motor indices, lowest and highest value of each of the five columns) of a list of names, as 5 x n arrays.

    The bounds say what ``validate_joint_command`` checks, column by column: q within its joint's range and the
    margin, |dq| within what the robot's float32 holds, |tau| within the effort limit, kp and kd within
    0 and their maximum. NaN fails every comparison, and an infinity every bound."""
    indices, limits, lows, highs = _indices(names, allowed)
    n, big = len(indices), MAX_ABS_DQ
    low = np.array([lows, (-big,) * n, tuple(-x for x in limits), (0.0,) * n, (0.0,) * n], dtype=np.float64)
    high = np.array([highs, (big,) * n, limits, (MAX_KP,) * n, (MAX_KD,) * n], dtype=np.float64)
    return indices, low, high


def validate_joint_block(names: Sequence[str], block: np.ndarray, *, allowed: Sequence[str]) -> JointFrame:
    """``validate_joint_command`` for the five columns given as one 5 x len(names) float64 array (q, dq, tau, kp,
    kd): the same checks, as two comparisons over the whole array; a refused command is explained joint by joint
    by ``validate_joint_command`` itself."""
    n = len(names)
    if n and block.shape == (5, n):
        indices, low, high = _block_bounds(tuple(names), tuple(allowed))
        if (low <= block).all() and (block <= high).all():
            q, dq, tau, kp, kd = block
            return JointFrame(indices, q, dq, tau, kp, kd, block)
    return validate_joint_command(names, *block.tolist(), allowed=allowed)


def _explain(names: Sequence[str], q: Sequence[float], dq: Sequence[float], tau: Sequence[float],
             kp: Sequence[float], kd: Sequence[float], allowed: Sequence[str]) -> None:
    """Raise JointCommandError naming the first problem, joint by joint (a refused command only)."""
    _check_lengths(names, {"q": q, "dq": dq, "tau": tau, "kp": kp, "kd": kd}, allow_empty={"dq", "tau"})
    indices = _check_names(names, allowed)
    for i, motor in enumerate(indices):
        cmd = MotorCommand(q=_value(q, i), dq=_value(dq, i), tau=_value(tau, i), kp=_value(kp, i), kd=_value(kd, i))
        if not all(isfinite(v) for v in (cmd.q, cmd.dq, cmd.tau, cmd.kp, cmd.kd)):
            raise JointCommandError(f"non-finite value for {names[i]}: {cmd}")
        if abs(cmd.dq) > MAX_ABS_DQ:
            raise JointCommandError(f"dq {cmd.dq} of {names[i]} does not fit the robot's float32")
        low, high = JOINT_RANGE_RAD[motor]
        if not low - RANGE_MARGIN_RAD <= cmd.q <= high + RANGE_MARGIN_RAD:
            raise JointCommandError(f"q {cmd.q} of {names[i]} is outside its range [{low}, {high}] rad "
                                    f"(+- {RANGE_MARGIN_RAD} rad allowed)")
        if not 0.0 <= cmd.kp <= MAX_KP or not 0.0 <= cmd.kd <= MAX_KD:
            raise JointCommandError(f"gains of {names[i]} out of range (0 <= kp <= {MAX_KP}, 0 <= kd <= {MAX_KD})")
        if abs(cmd.tau) > EFFORT_LIMIT_NM[motor]:
            limit = EFFORT_LIMIT_NM[motor]
            raise JointCommandError(f"tau {cmd.tau} of {names[i]} exceeds its effort limit {limit} N m")


def _value(values: Sequence[float], i: int) -> float:
    return float(values[i]) if len(values) else 0.0


def validate_lowcmd(
    names: Sequence[str],
    q: Sequence[float],
    dq: Sequence[float],
    tau: Sequence[float],
    kp: Sequence[float],
    kd: Sequence[float],
) -> JointFrame:
    """Low-level commands may name any of the 29 joints; the joints not named are damped."""
    return validate_joint_command(names, q, dq, tau, kp, kd, allowed=JOINT_NAMES)


def validate_lowcmd_block(names: Sequence[str], block: np.ndarray) -> JointFrame:
    """``validate_lowcmd`` for the five columns as one 5 x n array."""
    return validate_joint_block(names, block, allowed=JOINT_NAMES)


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


def damping_frame() -> JointFrame:
    """All 29 joints soft: kp 0, kd > 0 (what silence on rt/lowcmd turns into)."""
    return DAMPING
