"""A 5 x n block goes into a LowCmdFrame as the same bytes as its five columns: the block path of ~/lowcmd sends
byte for byte what the column path sends, whatever the joints' order, count and the frame's earlier contents."""

from __future__ import annotations

import math
import os
import random
import warnings
from collections.abc import Callable, Sequence

os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")  # the product's serialiser (one_dds_stack.py)

import numpy as np
from g1_mode_manager_msgs.msg import JointCommand
from rclpy.serialization import serialize_message

from g1_mode_manager.core.joint_commands import (
    MAX_KD,
    MAX_KP,
    JointFrame,
    validate_lowcmd,
    validate_lowcmd_block,
)
from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.node.joint_command_cdr import JointCommandReader
from g1_mode_manager.protocol.dds import apply_robot_type_compat
from g1_mode_manager.protocol.motors import (
    DAMPING_KD,
    EFFORT_LIMIT_NM,
    JOINT_INDEX,
    JOINT_NAMES,
    JOINT_RANGE_RAD,
    NUM_JOINTS,
)
from g1_mode_manager.sdk.frames import LowCmdFrame, check_block, check_columns
from g1_mode_manager.sdk.lowcmd import build_lowcmd_frame

HEADER = b"\x00\x01\x00\x00"
Columns = list[list[float]]


def as_block(rng: random.Random, columns: Columns) -> np.ndarray:
    """A contiguous 5 x n block, or a read-only view with a gap between rows (as ~/lowcmd's reader gives it)."""
    n = len(columns[0])
    if rng.random() < 0.5:
        return np.array(columns, dtype=np.float64).reshape(5, n)
    wide = np.zeros((5, n + 1), dtype=np.float64)
    wide[:, 1:] = columns
    view = wide[:, 1:]
    view.flags.writeable = False
    return view


def wire(frame: LowCmdFrame) -> tuple[tuple[bytes, int], bytes]:
    return frame.pack(), frame.cdr(HEADER)


def any_values(rng: random.Random, n: int) -> Columns:
    """Finite values of any size (float32 rounding, overflow to inf, denormals, -0.0) and gains >= 0."""

    def value() -> float:
        return rng.choice((rng.uniform(-10.0, 10.0), rng.uniform(-1e6, 1e6), 0.1, -0.0, 1e-40, -1e-45, 3.4028235e38,
                           3.4028236e38, 1e300, -1e300, math.pi))

    return [[value() for _ in range(n)] for _ in range(3)] + [[abs(value()) for _ in range(n)] for _ in range(2)]


def valid_values(rng: random.Random, motors: Sequence[int]) -> Columns:
    """What ~/lowcmd's check passes: q within range and margin, |tau| within the effort limit, gains in bounds."""
    q = [rng.uniform(JOINT_RANGE_RAD[m][0] - 0.5, JOINT_RANGE_RAD[m][1] + 0.5) for m in motors]
    dq = [rng.uniform(-30.0, 30.0) for _ in motors]
    tau = [rng.uniform(-EFFORT_LIMIT_NM[m], EFFORT_LIMIT_NM[m]) for m in motors]
    kp = [rng.choice((0.0, -0.0, MAX_KP, rng.uniform(0.0, MAX_KP))) for _ in motors]
    kd = [rng.choice((0.0, MAX_KD, DAMPING_KD, rng.uniform(0.0, MAX_KD))) for _ in motors]
    return [q, dq, tau, kp, kd]


def refusal(check: Callable[..., None], *args: object) -> str:
    """What ``check("lowcmd", *args)`` refuses with ("" if nothing)."""
    try:
        check("lowcmd", *args)
    except ValueError as exc:
        return str(exc)
    return ""


def test_check_block_refuses_what_check_columns_refuses_with_the_same_words() -> None:
    rng = random.Random(5)
    refused = accepted = 0
    for _ in range(3000):
        n = rng.randint(0, NUM_JOINTS)
        columns = any_values(rng, n)
        for _ in range(rng.choice((0, 0, 1, 2))):
            if n:
                c = rng.randrange(5)
                columns[c][rng.randrange(n)] = rng.choice((math.nan, math.inf, -math.inf, -1e-300, -1.0, -0.0,
                                                          -5e-324))
        by_columns = refusal(check_columns, *columns)
        by_block = refusal(check_block, np.array(columns, dtype=np.float64).reshape(5, n))
        assert by_block == by_columns, columns
        refused += bool(by_columns)
        accepted += not by_columns
    assert refused > 400 and accepted > 1500
    assert refusal(check_block, np.array([[-1.0], [-2.0], [-3.0], [0.0], [-0.0]])) == ""  # only gains must be >= 0


def test_set_block_writes_the_bytes_set_columns_writes() -> None:
    rng = random.Random(8)
    in_order = 0
    for case in range(1500):
        n = rng.randint(1, NUM_JOINTS) if case % 3 else 5  # 5: a block of the frame's five fields' shape
        indices = tuple(range(n)) if rng.random() < 0.5 else tuple(rng.sample(range(NUM_JOINTS), n))
        in_order += indices == tuple(range(n))
        columns = any_values(rng, n)
        by_columns, by_block = LowCmdFrame(), LowCmdFrame()
        mode = rng.choice((0, 1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # 1e300 overflows float32 to inf on both paths
            if rng.random() < 0.5:  # both held an earlier frame: what is not overwritten must stay the same in both
                earlier = any_values(rng, NUM_JOINTS)
                for frame in (by_columns, by_block):
                    frame.set_header(0, 5)
                    frame.set_columns(tuple(range(NUM_JOINTS)), 1, earlier)
            by_columns.set_columns(indices, mode, columns)
            by_block.set_block(indices, mode, as_block(rng, columns))
        assert wire(by_block) == wire(by_columns), (indices, columns)
    assert in_order > 500


def test_set_block_puts_each_value_in_its_motor_and_field() -> None:
    """Against the message itself, not the other path: motor i's q..kd are row 0..4 of column k."""
    rng = random.Random(9)
    for n in (1, 2, 5, 6, 29):
        indices = tuple(rng.sample(range(NUM_JOINTS), n))
        columns = [[float(100 * f + k) for k in range(n)] for f in range(5)]
        frame = LowCmdFrame()
        frame.set_block(indices, 1, np.array(columns))
        motors = frame.to_message().motor_cmd
        for k, motor in enumerate(indices):
            m = motors[motor]
            assert (m.mode, m.q, m.dq, m.tau, m.kp, m.kd) == (1, *(float(100 * f + k) for f in range(5)))
        for motor in set(range(len(motors))) - set(indices):
            assert (motors[motor].mode, motors[motor].q, motors[motor].kd) == (0, 0.0, 0.0)


def test_a_changed_header_changes_the_bytes() -> None:
    frame = LowCmdFrame()
    frame.set_columns((0, 1), 1, [[0.5, 0.25]] * 5)
    seen = []
    for header in ((0, 5), (0, 6), (0, 5), (1, 5), (0, 5), (0, 0), (0, 255)):
        frame.set_header(*header)
        seen.append(wire(frame))
        message = frame.to_message()
        assert (message.mode_pr, message.mode_machine) == header
    assert seen[0] != seen[1] and seen[0] != seen[3] and seen[5] != seen[6] and seen[1] != seen[6]
    assert seen[0] == seen[2] == seen[4]
    fresh = LowCmdFrame()
    fresh.set_columns((0, 1), 1, [[0.5, 0.25]] * 5)
    fresh.set_header(0, 255)
    assert wire(fresh) == seen[6]


def frames_of(rng: random.Random, names: Sequence[str], columns: Columns) -> tuple[JointFrame, JointFrame]:
    """The same command checked as a block and as five columns."""
    block = as_block(rng, columns)
    by_block = validate_lowcmd_block(names, block)
    assert by_block.block is block
    return by_block, validate_lowcmd(names, *columns)


def test_build_lowcmd_frame_from_a_block_is_the_frame_from_columns() -> None:
    rng = random.Random(10)
    reused_block, reused_columns = LowCmdFrame(), LowCmdFrame()  # one frame each, kept across commands
    counts = set()
    for case in range(800):
        n = rng.choice((NUM_JOINTS, rng.randint(1, NUM_JOINTS)))  # fewer than 29: the rest damped
        names = list(JOINT_NAMES[:n]) if rng.random() < 0.4 else rng.sample(JOINT_NAMES, n)
        counts.add(n)
        by_block, by_columns = frames_of(rng, names, valid_values(rng, [JOINT_INDEX[x] for x in names]))
        mode_machine = rng.choice((5, 5, 5, 6, 0, 255))
        expected = wire(build_lowcmd_frame(LowCmdFrame(), by_columns, mode_machine))
        assert wire(build_lowcmd_frame(LowCmdFrame(), by_block, mode_machine)) == expected
        assert wire(build_lowcmd_frame(reused_block, by_block, mode_machine)) == expected, case
        assert wire(build_lowcmd_frame(reused_columns, by_columns, mode_machine)) == expected, case
        motors = reused_block.to_message().motor_cmd
        for i in range(NUM_JOINTS):
            assert (motors[i].mode, motors[i].kd) == (1, np.float32(by_columns[i].kd)), i
    assert len(counts) > 20


def test_a_later_frame_naming_fewer_joints_leaves_nothing_of_the_earlier_one() -> None:
    rng = random.Random(12)
    for _ in range(100):
        frame = LowCmdFrame()
        for n in sorted(rng.sample(range(1, NUM_JOINTS + 1), 6), reverse=True):  # fewer and fewer joints
            names = rng.sample(JOINT_NAMES, n)
            columns = valid_values(rng, [JOINT_INDEX[x] for x in names])
            by_block, by_columns = frames_of(rng, names, columns)
            expected = wire(build_lowcmd_frame(LowCmdFrame(), by_columns, 5))
            assert wire(build_lowcmd_frame(frame, by_block, 5)) == expected
            message = frame.to_message()
            named = {JOINT_INDEX[x] for x in names}
            for motor in set(range(NUM_JOINTS)) - named:
                m = message.motor_cmd[motor]
                assert (m.mode, m.q, m.dq, m.tau, m.kp, m.kd) == (1, 0.0, 0.0, 0.0, 0.0, DAMPING_KD)


def test_the_frame_from_a_block_is_what_cyclonedds_serialises() -> None:
    apply_robot_type_compat()
    rng = random.Random(14)
    frame = LowCmdFrame()
    for _ in range(40):
        names = rng.sample(JOINT_NAMES, rng.randint(1, NUM_JOINTS))
        by_block, _ = frames_of(rng, names, valid_values(rng, [JOINT_INDEX[x] for x in names]))
        build_lowcmd_frame(frame, by_block, 5)
        expected = frame.to_message().serialize()
        assert frame.cdr(expected[:4]) == expected


def test_lowcmd_bytes_in_and_out_the_same_on_both_paths() -> None:
    """~/lowcmd's bytes to rt/lowcmd's: reader.block, the block check and set_block give what fields, the column
    check and set_columns give."""
    rng = random.Random(15)
    reader, frame = JointCommandReader(), LowCmdFrame()
    for sec in range(300):
        n = rng.choice((NUM_JOINTS, rng.randint(1, NUM_JOINTS)))
        names = rng.sample(JOINT_NAMES, n)
        columns = valid_values(rng, [JOINT_INDEX[x] for x in names])
        message = JointCommand(name=names, q=columns[0], dq=columns[1], tau=columns[2], kp=columns[3], kd=columns[4])
        message.stamp.sec = sec
        data = serialize_message(message)
        got = reader.block(data)
        assert got is not None
        by_block = validate_lowcmd_block(*got)
        assert by_block.block is got[1]
        by_columns = validate_lowcmd(*JointCommandReader().fields(data))
        assert wire(build_lowcmd_frame(frame, by_block, 5)) == wire(build_lowcmd_frame(LowCmdFrame(), by_columns, 5))
        commands = [MotorCommand(*(float(v) for v in (c.q, c.dq, c.tau, c.kp, c.kd))) for c in by_block]
        assert wire(build_lowcmd_frame(LowCmdFrame(), commands, 5)) == wire(frame)


def test_build_lowcmd_frame_refuses_a_bad_block_as_it_refuses_bad_columns() -> None:
    """A JointFrame made without the joint check (a controller's, say): the frame's own last check still holds, on
    the block path as on the column path, and nothing of the bad command is written."""
    rng = random.Random(16)
    for _ in range(300):
        n = rng.randint(1, NUM_JOINTS)
        indices = tuple(rng.sample(range(NUM_JOINTS), n))
        columns = valid_values(rng, indices)
        c = rng.randrange(5)
        columns[c][rng.randrange(n)] = rng.choice((math.nan, math.inf, -math.inf, -1e-9 if c >= 3 else math.nan))
        block = as_block(rng, columns)
        by_block = JointFrame(indices, *block, block)
        by_columns = JointFrame(indices, *(tuple(column) for column in columns))
        frame = LowCmdFrame()
        build_lowcmd_frame(frame, validate_lowcmd(list(JOINT_NAMES), *valid_values(rng, range(NUM_JOINTS))), 5)
        before = wire(frame)
        said = [build_refusal(frame, commands) for commands in (by_block, by_columns)]
        assert said[0] == said[1] != "", said
        assert wire(frame) == before


def build_refusal(frame: LowCmdFrame, commands: JointFrame) -> str:
    """What ``build_lowcmd_frame`` refuses ``commands`` with ("" if nothing)."""
    try:
        build_lowcmd_frame(frame, commands, 5)
    except ValueError as exc:
        return str(exc)
    return ""
