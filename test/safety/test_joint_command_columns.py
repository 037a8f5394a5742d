"""The column-wise joint command check accepts exactly what a joint-by-joint check accepts, and refuses the rest
with the same reason: the fast path of a 500 Hz relay must never pass a command the plain rules refuse."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from g1_mode_manager.core.joint_commands import (
    MAX_ABS_DQ,
    MAX_KD,
    MAX_KP,
    RANGE_MARGIN_RAD,
    JointCommandError,
    validate_lowcmd,
)
from g1_mode_manager.protocol.motors import DAMPING_KD, EFFORT_LIMIT_NM, JOINT_INDEX, JOINT_NAMES, JOINT_RANGE_RAD


def reference(names, q, dq, tau, kp, kd) -> list[tuple[float, ...]]:
    """The plain rules, joint by joint: the 29 (q, dq, tau, kp, kd) in motor order, or JointCommandError."""
    n = len(names)
    if n == 0:
        raise JointCommandError("no joint names given")
    for field, values in (("q", q), ("dq", dq), ("tau", tau), ("kp", kp), ("kd", kd)):
        if not (len(values) == 0 and field in ("dq", "tau")) and len(values) != n:
            raise JointCommandError(f"{field} has {len(values)} entries for {n} joint names")
    if any(name not in JOINT_INDEX for name in names) or len(set(names)) != n:
        raise JointCommandError("names")
    frame = [(0.0, 0.0, 0.0, 0.0, DAMPING_KD)] * 29
    for i, name in enumerate(names):
        motor = JOINT_INDEX[name]
        cmd = (float(q[i]), float(dq[i]) if dq else 0.0, float(tau[i]) if tau else 0.0, float(kp[i]), float(kd[i]))
        if not all(math.isfinite(v) for v in cmd):
            raise JointCommandError("non-finite")
        if abs(cmd[1]) > MAX_ABS_DQ:  # the robot's frames hold float32
            raise JointCommandError("dq")
        low, high = JOINT_RANGE_RAD[motor]
        if not low - RANGE_MARGIN_RAD <= cmd[0] <= high + RANGE_MARGIN_RAD:
            raise JointCommandError("range")
        if not 0.0 <= cmd[3] <= MAX_KP or not 0.0 <= cmd[4] <= MAX_KD:
            raise JointCommandError("gains")
        if abs(cmd[2]) > EFFORT_LIMIT_NM[motor]:
            raise JointCommandError("effort limit")
        frame[motor] = cmd
    return frame


edgy = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                 st.sampled_from([0.0, -0.0, 1e-300, -1e-9, MAX_ABS_DQ, -MAX_ABS_DQ, math.nextafter(MAX_ABS_DQ, math.inf)]))
gain = st.one_of(st.floats(-1.0, 600.0), st.sampled_from([0.0, MAX_KP, MAX_KD, math.nan, math.inf, -0.0]), edgy)
torque = st.one_of(st.floats(-140.0, 140.0), st.sampled_from([5.0, -5.0, 25.0, 88.0, 139.0, -139.0]), edgy)
some_names = st.lists(st.sampled_from([*JOINT_NAMES, "knee", ""]), min_size=0, max_size=31)


@st.composite
def commands(draw):
    names = draw(st.one_of(some_names, st.permutations(JOINT_NAMES), st.just(list(JOINT_NAMES))))
    n = len(names)

    def column(values, may_be_empty: bool):
        size = draw(st.sampled_from([n] * 8 + [0, n + 1, max(0, n - 1)])) if may_be_empty else \
            draw(st.sampled_from([n] * 12 + [n + 1, max(0, n - 1)]))
        return draw(st.lists(values, min_size=size, max_size=size))

    return (names, column(st.floats(-4.0, 4.0) | edgy, False), column(edgy, True), column(torque, True),
            column(gain, False), column(gain, False))


@settings(max_examples=400, deadline=None)
@given(commands())
def test_column_check_accepts_and_refuses_what_the_joint_by_joint_rules_do(cmd) -> None:
    try:
        expected = reference(*cmd)
    except JointCommandError:
        expected = None
    try:
        frame = validate_lowcmd(*cmd)
    except JointCommandError as exc:
        assert expected is None, f"refused ({exc}) what the rules accept"
        assert str(exc), "a refusal says why"
        return
    assert expected is not None, "accepted what the rules refuse"
    got = [(c.q, c.dq, c.tau, c.kp, c.kd) for c in frame]
    assert got == expected
