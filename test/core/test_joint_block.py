"""The numpy check of a 5 x n block accepts exactly what the check of five columns accepts, gives the same frame, and
refuses the rest with the same explanation: ~/lowcmd's fast path must never pass a command the plain rules refuse."""

from __future__ import annotations

import math
import random
import struct
import sys
from collections import Counter
from collections.abc import Callable, Sequence

import numpy as np

from g1_mode_manager.core.joint_commands import (
    MAX_ABS_DQ,
    MAX_KD,
    MAX_KP,
    RANGE_MARGIN_RAD,
    JointCommandError,
    JointFrame,
    validate_joint_block,
    validate_joint_command,
    validate_lowcmd,
    validate_lowcmd_block,
)
from g1_mode_manager.protocol.motors import (
    ARM_SDK_JOINT_NAMES,
    EFFORT_LIMIT_NM,
    JOINT_INDEX,
    JOINT_NAMES,
    JOINT_RANGE_RAD,
    NUM_JOINTS,
)

BIG = sys.float_info.max
NAN_PAYLOAD = struct.unpack("<d", struct.pack("<Q", 0x7FF0000000000001))[0]  # a signalling NaN
NON_FINITE = (math.nan, -math.nan, NAN_PAYLOAD, math.inf, -math.inf)
Columns = list[list[float]]


def _inward(x: float, toward: float) -> float:
    return math.nextafter(x, toward)


def q_values(motor: int, good: bool) -> tuple[float, ...]:
    """Position targets at, just inside and (not ``good``) just outside the joint's range and margin."""
    low = JOINT_RANGE_RAD[motor][0] - RANGE_MARGIN_RAD  # the same float expressions as the check's
    high = JOINT_RANGE_RAD[motor][1] + RANGE_MARGIN_RAD
    if good:
        return (low, high, _inward(low, 0.0), _inward(high, 0.0), *JOINT_RANGE_RAD[motor], 0.0, -0.0,
                (low + high) / 2, low + 1e-12, high - 1e-12)
    return (_inward(low, -math.inf), _inward(high, math.inf), low - 1e-9, high + 1e-9, low - 1.0, high + 100.0,
            -BIG, BIG, *NON_FINITE)


def dq_values(good: bool) -> tuple[float, ...]:
    """Velocity targets: any the robot's float32 holds; larger ones would reach it as infinity."""
    if good:
        return (0.0, -0.0, MAX_ABS_DQ, -MAX_ABS_DQ, _inward(MAX_ABS_DQ, 0.0), 5e-324, 123.5, -40.0)
    return (_inward(MAX_ABS_DQ, math.inf), -_inward(MAX_ABS_DQ, math.inf), 1e308, -1e308, BIG, -BIG, *NON_FINITE)


def tau_values(motor: int, good: bool) -> tuple[float, ...]:
    limit = EFFORT_LIMIT_NM[motor]
    if good:
        return (limit, -limit, _inward(limit, 0.0), -_inward(limit, 0.0), 0.0, -0.0, limit / 3)
    return (_inward(limit, math.inf), -_inward(limit, math.inf), limit + 1e-9, -limit - 1.0, BIG, -BIG, *NON_FINITE)


def gain_values(maximum: float, good: bool) -> tuple[float, ...]:
    if good:
        return (0.0, -0.0, 5e-324, maximum, _inward(maximum, 0.0), maximum / 2, 1.0)
    return (-5e-324, -1e-12, -1.0, _inward(maximum, math.inf), maximum + 1e-9, maximum * 2, BIG, -BIG, *NON_FINITE)


def values_of(column: int, motor: int, good: bool) -> tuple[float, ...]:
    if column == 0:
        return q_values(motor, good)
    if column == 1:
        return dq_values(good)
    if column == 2:
        return tau_values(motor, good)
    return gain_values(MAX_KP if column == 3 else MAX_KD, good)


def good_columns(rng: random.Random, motors: Sequence[int]) -> Columns:
    return [[rng.choice(values_of(c, m, True)) for m in motors] for c in range(5)]


def spoil(rng: random.Random, columns: Columns, motors: Sequence[int]) -> None:
    """One to three values anywhere out of bounds (any column: q, dq, tau, kp, kd)."""
    for _ in range(rng.randint(1, 3)):
        c, k = rng.randrange(5), rng.randrange(len(motors))
        columns[c][k] = rng.choice(values_of(c, motors[k], False))


def as_block(rng: random.Random, columns: Columns) -> np.ndarray:
    """The columns as a 5 x n float64 block: contiguous, or (as ~/lowcmd's reader gives it) a read-only view with a
    gap between its rows."""
    n = len(columns[0]) if columns else 0
    if rng.random() < 0.5:
        return np.array(columns, dtype=np.float64).reshape(5, n)
    wide = np.zeros((5, n + 1), dtype=np.float64)
    wide[:, 1:] = columns
    view = wide[:, 1:]
    view.flags.writeable = False
    return view


def outcome(check: Callable[[], JointFrame]) -> JointFrame | str:
    try:
        return check()
    except JointCommandError as exc:
        return f"refused: {exc}"


def bits(values: Sequence[float]) -> list[bytes]:
    """Each value's 8 bytes: tells -0.0 from 0.0 and a NaN's payload."""
    return [struct.pack("<d", float(v)) for v in values]


def assert_same_frame(by_block: JointFrame, by_columns: JointFrame, block: np.ndarray) -> None:
    assert by_block.indices == by_columns.indices
    for field in ("q", "dq", "tau", "kp", "kd"):
        got, expected = getattr(by_block, field), getattr(by_columns, field)
        assert [float(v) for v in got] == [float(v) for v in expected], field
        assert bits(got) == bits(expected), field
    assert by_block.block is block
    assert len(by_block) == NUM_JOINTS and by_block.damping == by_columns.damping
    for motor in range(-NUM_JOINTS, NUM_JOINTS):
        assert by_block[motor] == by_columns[motor], motor
        assert all(isinstance(v, float) for v in (by_block[motor].q, by_block[motor].kd))


def compare(names: Sequence[str], columns: Columns, block: np.ndarray, *, allowed: Sequence[str] | None) -> str:
    """Both checks of one command; what they said (a refusal's text, or "accepted")."""
    if allowed is None:
        by_columns = outcome(lambda: validate_lowcmd(names, *columns))
        by_block = outcome(lambda: validate_lowcmd_block(names, block))
    else:
        by_columns = outcome(lambda: validate_joint_command(names, *columns, allowed=allowed))
        by_block = outcome(lambda: validate_joint_block(names, block, allowed=allowed))
    if isinstance(by_columns, str) or isinstance(by_block, str):
        assert by_block == by_columns, (names, columns)
        assert isinstance(by_block, str)
        return by_block
    assert_same_frame(by_block, by_columns, block)
    return "accepted"


def reason(said: str) -> str:
    """A refusal's kind, for counting that every kind was met."""
    for kind in ("non-finite", "outside its range", "gains", "effort limit", "unknown", "duplicate", "entries",
                 "no joint names"):
        if kind in said:
            return kind
    return said


def test_the_block_check_agrees_with_the_column_check_near_every_bound() -> None:
    rng = random.Random(314159)
    seen: Counter[str] = Counter()
    for _ in range(6000):
        n = rng.choice((NUM_JOINTS, rng.randint(1, NUM_JOINTS)))
        names = rng.sample(JOINT_NAMES, n)
        motors = [JOINT_INDEX[name] for name in names]
        columns = good_columns(rng, motors)
        if rng.random() < 0.55:
            spoil(rng, columns, motors)
        seen[reason(compare(names, columns, as_block(rng, columns), allowed=None))] += 1
    assert seen["accepted"] > 1500, seen
    for kind in ("non-finite", "outside its range", "gains", "effort limit"):
        assert seen[kind] > 200, seen


def test_every_single_value_out_of_bounds_is_refused_the_same_way() -> None:
    """Each joint, each column, each value just past a bound, in an otherwise good command: none slips through."""
    rng = random.Random(2718)
    for motor in range(NUM_JOINTS):
        names = rng.sample(JOINT_NAMES, rng.randint(1, NUM_JOINTS))
        if JOINT_NAMES[motor] not in names:
            names[rng.randrange(len(names))] = JOINT_NAMES[motor]
        motors = [JOINT_INDEX[name] for name in names]
        k = names.index(JOINT_NAMES[motor])
        for column in range(5):
            for good in (True, False):
                for value in values_of(column, motor, good):
                    columns = good_columns(rng, motors)
                    columns[column][k] = value
                    said = compare(names, columns, as_block(rng, columns), allowed=None)
                    assert (said == "accepted") == good, (JOINT_NAMES[motor], column, value, said)


def test_names_unknown_duplicate_or_not_allowed_are_refused_the_same_way() -> None:
    rng = random.Random(1618)
    seen: Counter[str] = Counter()
    for _ in range(1500):
        allowed = rng.choice((None, ARM_SDK_JOINT_NAMES, JOINT_NAMES))
        pool = list(JOINT_NAMES if allowed is None else allowed)
        names = rng.sample(pool, rng.randint(1, len(pool)))
        kind = rng.randrange(4)
        if kind == 0:
            names[rng.randrange(len(names))] = rng.choice(("knee", "", "LEFT_KNEE_JOINT", "left_knee_joint "))
        elif kind == 1:
            names.append(rng.choice(names))
            rng.shuffle(names)
        elif kind == 2 and allowed is not None and allowed is not JOINT_NAMES:
            names[rng.randrange(len(names))] = JOINT_NAMES[rng.randrange(12)]  # a leg joint: not on rt/arm_sdk
        motors = [JOINT_INDEX.get(name, 0) for name in names]
        columns = good_columns(rng, motors)
        if rng.random() < 0.3:
            spoil(rng, columns, motors)  # a bad value too: the names are still what is said first
        said = compare(names, columns, as_block(rng, columns), allowed=allowed)
        seen[reason(said)] += 1
        if kind in (0, 1):
            assert said != "accepted"
    assert seen["unknown"] > 300 and seen["duplicate"] > 300 and seen["accepted"] > 100, seen


def test_arm_sdk_names_agree_near_every_bound() -> None:
    rng = random.Random(1414)
    seen: Counter[str] = Counter()
    for _ in range(1500):
        names = rng.sample(ARM_SDK_JOINT_NAMES, rng.randint(1, len(ARM_SDK_JOINT_NAMES)))
        motors = [JOINT_INDEX[name] for name in names]
        columns = good_columns(rng, motors)
        if rng.random() < 0.5:
            spoil(rng, columns, motors)
        seen[reason(compare(names, columns, as_block(rng, columns), allowed=ARM_SDK_JOINT_NAMES))] += 1
    assert seen["accepted"] > 400 and len(seen) >= 5, seen


def test_a_block_of_another_shape_is_refused_as_the_columns_are() -> None:
    rng = random.Random(1732)
    for _ in range(300):
        n = rng.randint(1, NUM_JOINTS)
        names = rng.sample(JOINT_NAMES, n)
        m = rng.choice([k for k in (0, n - 1, n + 1, n + 5) if k != n and k >= 0])
        motors = [JOINT_INDEX[name] for name in rng.choices(JOINT_NAMES, k=m)]
        columns = good_columns(rng, motors)
        said = compare(names, columns, as_block(rng, columns), allowed=None)
        assert "entries" in said, said
    assert compare([], [[]] * 5, np.zeros((5, 0)), allowed=None) == "refused: no joint names given"


def test_zero_rows_give_the_frame_of_empty_dq_and_tau() -> None:
    """A message without dq and tau (the usual low-gain one): the column check fills zeros; a block of zeros is it."""
    rng = random.Random(99)
    for _ in range(300):
        names = rng.sample(JOINT_NAMES, rng.randint(1, NUM_JOINTS))
        motors = [JOINT_INDEX[name] for name in names]
        columns = good_columns(rng, motors)
        columns[1] = [0.0] * len(names)
        columns[2] = [0.0] * len(names)
        block = as_block(rng, columns)
        by_columns = validate_lowcmd(names, columns[0], [], [], columns[3], columns[4])
        assert_same_frame(validate_lowcmd_block(names, block), by_columns, block)
