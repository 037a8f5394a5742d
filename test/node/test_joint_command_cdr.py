"""~/lowcmd's bytes read without a message object give what rclpy's own deserialisation gives."""

from __future__ import annotations

import math
import os
import random
import struct
import sys
from collections.abc import Sequence

os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")  # the product's serialiser (one_dds_stack.py)

import numpy as np
from g1_mode_manager_msgs.msg import JointCommand
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

from g1_mode_manager.node.joint_command_cdr import JointCommandReader
from g1_mode_manager.protocol.motors import JOINT_NAMES

names = st.lists(st.one_of(st.sampled_from(JOINT_NAMES), st.text(max_size=9)), max_size=31)
column = st.lists(st.floats(allow_nan=False, width=64), max_size=31)


def _message(n, q, dq, tau, kp, kd, sec=0) -> JointCommand:
    msg = JointCommand(name=n, q=q, dq=dq, tau=tau, kp=kp, kd=kd)
    msg.stamp.sec = sec
    return msg


@settings(max_examples=150, deadline=None)
@given(names, column, column, column, column, column, st.integers(0, 2**31 - 1))
def test_fields_equal_the_message(n, q, dq, tau, kp, kd, sec) -> None:
    data = serialize_message(_message(n, q, dq, tau, kp, kd, sec))
    msg = deserialize_message(data, JointCommand)
    expected = (tuple(msg.name), tuple(msg.q), tuple(msg.dq), tuple(msg.tau), tuple(msg.kp), tuple(msg.kd))
    assert JointCommandReader().fields(data) == expected


def test_the_names_are_reused_only_while_they_are_the_same() -> None:
    reader = JointCommandReader()
    data = serialize_message(_message(list(JOINT_NAMES), [0.1] * 29, [], [], [1.0] * 29, [2.0] * 29))
    first = reader.fields(data)
    again = reader.fields(serialize_message(_message(list(JOINT_NAMES), [0.2] * 29, [], [], [1.0] * 29, [2.0] * 29, 7)))
    assert again[0] == first[0] and again[1] == (0.2,) * 29
    if data[:2] == b"\x00\x01":  # the plain little-endian CDR that Fast DDS writes: the names' tuple is reused
        assert again[0] is first[0]
    # a longer list that starts with the same names, and a shorter one: read anew
    longer = reader.fields(serialize_message(_message([*JOINT_NAMES, "x"], [0.0] * 30, [], [], [0.0] * 30, [0.0] * 30)))
    assert longer[0] == (*JOINT_NAMES, "x")
    shorter = reader.fields(serialize_message(_message(list(JOINT_NAMES[:2]), [0.3, 0.4], [], [], [1.0] * 2, [2.0] * 2)))
    assert shorter[0] == tuple(JOINT_NAMES[:2]) and shorter[1] == (0.3, 0.4)


def _with_padding(data: bytes, fill: int) -> bytes:
    """``data`` with the alignment padding between its names set to ``fill`` (a serialiser leaves it as it was)."""
    out = bytearray(data)
    (count,) = struct.unpack_from("<I", out, 12)
    at = 16
    for _ in range(count):
        while (at - 4) % 4:
            out[at] = fill
            at += 1
        (size,) = struct.unpack_from("<I", out, at)
        at += 4 + size
    return bytes(out)


def test_the_names_are_reused_whatever_the_padding_between_them_holds() -> None:
    data = serialize_message(_message(list(JOINT_NAMES), [0.1] * 29, [], [], [1.0] * 29, [2.0] * 29))
    assert data[:2] == b"\x00\x01"
    reader = JointCommandReader()
    first = reader.fields(_with_padding(data, 0x00))
    again = reader.fields(_with_padding(data, 0xA5))
    assert _with_padding(data, 0x00) != _with_padding(data, 0xA5), "the names have no padding: nothing was tested"
    assert again == first == reader.fields(data) == JointCommandReader().fields(_with_padding(data, 0xA5))
    assert again[0] is first[0]


def test_bytes_cut_short_are_an_error_never_a_command() -> None:
    data = serialize_message(_message(list(JOINT_NAMES), [0.5] * 29, [], [], [1.0] * 29, [2.0] * 29))
    reader = JointCommandReader()
    reader.fields(data)  # the names are remembered: the cut message takes the cached path
    for cut in (len(data) - 300, len(data) // 2, 40):  # (rclpy leaves a few spare bytes at the end)
        try:
            fields = reader.fields(data[:cut])
        except Exception:
            continue
        raise AssertionError(f"{cut} bytes of {len(data)} read as a command: {fields}")


# --- block: the five columns as one 5 x n view of the bytes --------------------------------------------------------

_SPECIAL = (0.0, -0.0, math.nan, -math.nan, math.inf, -math.inf, 1e308, -1e308, sys.float_info.max, -sys.float_info.max,
            5e-324, -5e-324, sys.float_info.min, 1.0, -1.0, 500.0, 50.0)


def _double(rng: random.Random) -> float:
    """A special value, an ordinary one, or any 64 bits (NaNs with payloads, signalling ones, denormals)."""
    pick = rng.random()
    if pick < 0.3:
        return rng.choice(_SPECIAL)
    if pick < 0.7:
        return rng.uniform(-1e4, 1e4)
    return struct.unpack("<d", rng.randbytes(8))[0]


def _columns(rng: random.Random, n: int) -> list[list[float]]:
    return [[_double(rng) for _ in range(n)] for _ in range(5)]


def _bits(values: object) -> np.ndarray:
    """The 64 bits of each double: equality that tells NaN payloads and -0.0 apart."""
    return np.ascontiguousarray(np.asarray(values, dtype=np.float64)).view(np.uint64)


def _serialised(names: Sequence[str], columns: Sequence[Sequence[float]], sec: int = 0) -> bytes:
    return serialize_message(_message(list(names), *(list(c) for c in columns), sec=sec))


def _encoded(names: Sequence[str], columns: Sequence[Sequence[float]], *, big_endian: bool = False,
             fill: int = 0) -> bytes:
    """XCDR1 of a JointCommand written here, not by rclpy: ``fill`` in every alignment gap, either byte order."""
    e = ">" if big_endian else "<"
    out = bytearray(b"\x00\x00\x00\x00" if big_endian else b"\x00\x01\x00\x00")

    def align(size: int) -> None:
        out.extend(bytes([fill]) * (-(len(out) - 4) % size))

    out += struct.pack(f"{e}iI", 7, 9)  # stamp
    out += struct.pack(f"{e}I", len(names))
    for name in names:
        align(4)
        raw = name.encode() + b"\0"
        out += struct.pack(f"{e}I", len(raw)) + raw
    for column in columns:
        align(4)
        out += struct.pack(f"{e}I", len(column))
        if column:
            align(8)
            out += struct.pack(f"{e}{len(column)}d", *column)
    return bytes(out)


def _assert_block_is(got: tuple[tuple[str, ...], np.ndarray] | None, names: Sequence[str],
                     columns: Sequence[Sequence[float]]) -> None:
    assert got is not None, "the usual message was not read as a block"
    got_names, block = got
    assert got_names == tuple(names)
    assert block.shape == (5, len(names)) and block.dtype == np.float64
    assert np.array_equal(_bits(block), _bits(columns))


def test_block_equals_fields_for_any_names_and_values() -> None:
    rng = random.Random(20240611)
    shared = JointCommandReader()  # one reader for every message: its cached layout meets every size and name list
    sizes = set()
    for case in range(600):
        n = rng.randint(1, 29)
        names = rng.sample(JOINT_NAMES, n)  # a subset, in any order
        columns = _columns(rng, n)
        data = _serialised(names, columns, sec=case)
        fields = JointCommandReader().fields(data)
        for reader in (shared, JointCommandReader()):
            got = reader.block(data)
            _assert_block_is(got, names, columns)
            assert got is not None
            assert got[0] == fields[0]
            assert np.array_equal(got[1], np.array(fields[1:]), equal_nan=True)
            assert np.array_equal(_bits(got[1]), _bits(fields[1:]))
        sizes.add(n)
    assert sizes == set(range(1, 30))


def test_block_ignores_what_the_padding_holds_and_matches_an_independent_encoding() -> None:
    rng = random.Random(7)
    reader = JointCommandReader()
    for _ in range(100):
        names = rng.sample(JOINT_NAMES, rng.randint(1, 29))
        columns = _columns(rng, len(names))
        for fill in (0x00, 0xA5, 0xFF, 0x1D):  # 0x1D: the count 29 in a gap must not pass for a count
            _assert_block_is(reader.block(_encoded(names, columns, fill=fill)), names, columns)
        _assert_block_is(reader.block(_serialised(names, columns)), names, columns)


def test_block_does_not_reuse_the_last_values_for_the_same_names_and_size() -> None:
    rng = random.Random(11)
    reader = JointCommandReader()
    names = rng.sample(JOINT_NAMES, 12)
    first_columns, second_columns = _columns(rng, 12), _columns(rng, 12)
    first_data, second_data = _serialised(names, first_columns), _serialised(names, second_columns)
    assert len(first_data) == len(second_data)
    first = reader.block(first_data)
    second = reader.block(second_data)
    _assert_block_is(second, names, second_columns)
    _assert_block_is(first, names, first_columns)  # the first view still shows its own message's values
    _assert_block_is(reader.block(first_data), names, first_columns)


def test_block_reads_other_names_of_the_same_size_anew() -> None:
    rng = random.Random(13)
    reader = JointCommandReader()
    n_same_size = 0
    last_size = None
    for _ in range(200):
        names = list(JOINT_NAMES)
        rng.shuffle(names)  # every order of the 29 names has the same size; the names' padding may differ
        columns = _columns(rng, 29)
        data = _serialised(names, columns)
        n_same_size += len(data) == last_size
        last_size = len(data)
        _assert_block_is(reader.block(data), names, columns)
    # names of one length swapped for others: same bytes but for the characters
    a, b = ["left_knee_joint", "waist_yaw_joint"], ["waist_yaw_joint", "left_knee_joint"]
    c = ["right_knee_joint", "left_elbow_joint"]
    for names in (a, b, c, a, [*a[:1], "waist_yaw_joinT"]):
        columns = _columns(rng, 2)
        _assert_block_is(reader.block(_serialised(names, columns)), names, columns)
    assert n_same_size > 150, "the messages were not of one size: the cached layout was never at stake"


def test_block_is_none_unless_all_five_columns_have_one_value_per_name() -> None:
    rng = random.Random(17)
    for n in (1, 2, 5, 17, 29):
        names = rng.sample(JOINT_NAMES, n)
        good = _columns(rng, n)
        good_data = _serialised(names, good)
        odd: list[list[list[float]]] = []
        for i in range(5):
            odd.append([c if j != i else [] for j, c in enumerate(good)])  # one column empty (dq or tau: the usual)
            odd.append([c if j != i else [*c, 1.5] for j, c in enumerate(good)])  # one column a value too long
            if n > 1:
                odd.append([c if j != i else c[:-1] for j, c in enumerate(good)])  # one column a value short
        odd.append([good[0], [], [], good[3], good[4]])  # dq and tau both empty
        odd.append([[*c, 0.25] for c in good])  # every column one longer than the names
        same_size = []
        for shorter in range(5):
            for longer in range(5):
                if shorter != longer:  # one column shortened, another lengthened: the message keeps its size
                    same_size.append([c[:-1] if j == shorter else [*c, 2.5] if j == longer else c
                                      for j, c in enumerate(good)])
        for columns in (*odd, *same_size):
            data = _serialised(names, columns)
            reader = JointCommandReader()
            _assert_block_is(reader.block(good_data), names, good)  # the layout of the usual message is cached
            assert reader.block(data) is None, [len(c) for c in columns]
            assert JointCommandReader().block(data) is None
            _assert_block_is(reader.block(good_data), names, good)
            fields = reader.fields(data)  # fields still reads it, as it is
            assert [len(c) for c in fields[1:]] == [len(c) for c in columns]
        for columns in same_size:
            assert len(_serialised(names, columns)) == len(good_data), "not the cached size: nothing was tested"
    assert JointCommandReader().block(_serialised([], [[], [], [], [], []])) is None


def test_block_is_none_for_other_encodings() -> None:
    rng = random.Random(19)
    names = rng.sample(JOINT_NAMES, 9)
    columns = _columns(rng, 9)
    data = _serialised(names, columns)
    assert data[:2] == b"\x00\x01"
    reader = JointCommandReader()
    _assert_block_is(reader.block(data), names, columns)  # the layout for this size and these names is cached
    for header in (b"\x00\x00", b"\x00\x02", b"\x00\x03", b"\x00\x06", b"\x00\x07", b"\x00\x08", b"\x00\x09",
                   b"\x00\x0a", b"\x00\x0b", b"\x01\x01", b"\x01\x00", b"\xff\xff"):
        for r in (reader, JointCommandReader()):
            assert r.block(header + data[2:]) is None, header
    big = _encoded(names, columns, big_endian=True)
    assert len(big) == len(data)
    assert reader.block(big) is None and JointCommandReader().block(big) is None
    _assert_block_is(reader.block(data), names, columns)


def test_block_of_cut_or_garbled_bytes_is_none_or_the_message_never_an_exception() -> None:
    rng = random.Random(23)
    for n in (1, 3, 29):
        names = rng.sample(JOINT_NAMES, n)
        columns = _columns(rng, n)
        data = _serialised(names, columns)
        exact = len(_encoded(names, columns))  # where the last double ends: rclpy may add spare bytes after it
        assert len(data) >= exact
        reader = JointCommandReader()
        _assert_block_is(reader.block(data[:exact]), names, columns)
        for cut in range(exact):
            assert reader.block(data[:cut]) is None, cut
            assert JointCommandReader().block(data[:cut]) is None, cut
            _assert_block_is(reader.block(data), names, columns)  # and back: nothing of the cut one was kept
    reader = JointCommandReader()
    read = 0
    for _ in range(3000):
        names = rng.sample(JOINT_NAMES, rng.randint(1, 29))
        data = bytearray(_serialised(names, _columns(rng, len(names))))
        for _ in range(rng.randint(1, 4)):  # a few bytes anywhere past the header, often a count or a length
            data[rng.randrange(4, len(data))] = rng.choice((0, 1, 2, 29, 30, 0x80, 0xFF, rng.randrange(256)))
        garbled = bytes(data)
        for r in (reader, JointCommandReader()):
            got = r.block(garbled)
            if got is not None:  # it parses as the usual message: then it is what the plain reading says
                read += 1
                fields = JointCommandReader().fields(garbled)
                assert got[0] == fields[0]
                assert np.array_equal(_bits(got[1]), _bits(fields[1:]))
    for size in range(0, 400, 3):
        noise = b"\x00\x01\x00\x00" + rng.randbytes(size)
        got = reader.block(noise)
        if got is not None:
            assert np.array_equal(_bits(got[1]), _bits(JointCommandReader().fields(noise)[1:]))
    assert read > 100, "no garbled message was read: the comparison never ran"


def test_the_block_is_a_read_only_view() -> None:
    names = list(JOINT_NAMES)
    columns = [[float(i + 10 * j) for i in range(29)] for j in range(5)]
    data = _serialised(names, columns)
    got = JointCommandReader().block(data)
    assert got is not None
    block = got[1]
    assert not block.flags.writeable
    try:
        block[3, 0] = 1.0
    except ValueError:
        pass
    else:
        raise AssertionError("the block is writable")
    assert np.shares_memory(block, np.frombuffer(data, dtype=np.uint8))  # a view of the message, not a copy
    _assert_block_is(got, names, columns)


def test_one_reader_through_a_stream_of_usual_and_odd_messages() -> None:
    """What the node does: block first, fields when block says no; names, sizes and shapes change on the way."""
    rng = random.Random(29)
    reader = JointCommandReader()
    usual = odd = 0
    for _ in range(1500):
        n = rng.choice((29, 29, 29, rng.randint(1, 29)))
        names = rng.sample(JOINT_NAMES, n) if rng.random() < 0.3 else list(JOINT_NAMES[:n])
        columns = _columns(rng, n)
        if rng.random() < 0.3:  # dq and tau left empty, or one column of another length
            columns[rng.choice((1, 2))] = []
            if rng.random() < 0.5:
                columns[rng.randrange(5)].append(0.5)
        data = _serialised(names, columns)
        got = reader.block(data)
        if all(len(c) == n for c in columns):
            usual += 1
            _assert_block_is(got, names, columns)
        else:
            odd += 1
            assert got is None
            fields = reader.fields(data)
            assert fields[0] == tuple(names)
            assert all(np.array_equal(_bits(f), _bits(c)) for f, c in zip(fields[1:], columns, strict=True))
    assert usual > 500 and odd > 200
