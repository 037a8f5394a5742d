"""g1_mode_manager_msgs/JointCommand from its serialised bytes: names and the five columns, without a message object.

At 500 Hz rclpy's conversion into a JointCommand (29 Python strings, five arrays) and back into lists costs
more than everything else the relay does. Here the bytes are read with ``struct``: a controller sends the
same joint names in every message, so the names' bytes are compared with the last message's (one
``unpack_from`` of their lengths and characters, no decoding) and their tuple reused; the five float64
sequences are unpacked as tuples. The alignment padding between the names is skipped, not compared: the
serialiser does not clear it, so it holds whatever its buffer held before.
Only plain little-endian CDR (what Fast DDS writes for ROS messages) is read this way; anything else,
or bytes that do not parse, goes through rclpy's own deserialisation.

``block`` reads the usual message (five columns of one length) as one 5 x n numpy view of the bytes, no float
made in Python: past the first column each column is its count, four bytes of padding and its doubles, so the
five lie in the bytes as rows of n + 1 doubles, the first holding the count.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from functools import lru_cache
from typing import Final

import numpy as np
from g1_mode_manager_msgs.msg import JointCommand
from rclpy.serialization import deserialize_message

#: Encapsulation header + builtin_interfaces/Time: the names' sequence starts here.
_NAMES_AT: Final = 4 + 8
_U32: Final = struct.Struct("<I")
_LITTLE_ENDIAN_PLAIN: Final = (b"\x00\x01",)  # CDR_LE (XCDR1): Fast DDS's encoding of ROS messages

Fields = tuple[tuple[str, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...],
               tuple[float, ...]]


@dataclass(frozen=True, slots=True)
class _Rows:
    """Where a message's five columns lie, all of ``n`` doubles: rows of n + 1 doubles from ``at``, each row's
    first slot holding the column's count; ``counts`` reads the five counts from ``counts_at``."""

    size: int
    n: int
    at: int
    counts: struct.Struct
    counts_at: int
    expected: tuple[int, ...]


@lru_cache(maxsize=64)
def _doubles(n: int) -> struct.Struct:
    return struct.Struct(f"<{n}d")


class JointCommandReader:
    """Reads JointCommand bytes; remembers the last names. One per subscription (not thread-safe)."""

    def __init__(self) -> None:
        self._layout: struct.Struct | None = None  # the last names' count, lengths and characters, padding skipped
        self._layout_values: tuple = ()
        self._names: tuple[str, ...] = ()
        self._rows: _Rows | None = None  # where the columns lie, for the last size and names

    def fields(self, data: bytes) -> Fields:
        """(names, q, dq, tau, kp, kd) of a serialised JointCommand."""
        if data[:2] in _LITTLE_ENDIAN_PLAIN:
            try:
                return self._read(data)
            except (struct.error, UnicodeDecodeError, ValueError):
                pass  # not what it should be: rclpy says what it is
        msg = deserialize_message(data, JointCommand)
        return (tuple(msg.name), tuple(msg.q), tuple(msg.dq), tuple(msg.tau), tuple(msg.kp),
                tuple(msg.kd))

    def block(self, data: bytes) -> tuple[tuple[str, ...], np.ndarray] | None:
        """(names, the five columns as a read-only 5 x n float64 view of ``data``), or None when the message is
        not the usual one (another encoding, a column of another length, bytes that do not parse): ``fields``
        reads those."""
        if data[:2] not in _LITTLE_ENDIAN_PLAIN:
            return None
        rows = self._rows
        if rows is None or len(data) != rows.size or not self._same_names(data):
            rows = self._rows = self._rows_of(data)
            if rows is None:
                return None
        if rows.counts.unpack_from(data, rows.counts_at) != rows.expected:
            return None
        view = np.frombuffer(data, dtype="<f8", count=5 * (rows.n + 1), offset=rows.at)
        return self._names, view.reshape(5, rows.n + 1)[:, 1:]

    def _rows_of(self, data: bytes) -> _Rows | None:
        """Where the five columns lie in a message of this size with these names, if they all have one per name."""
        try:
            names, at, layout = _read_names(data)
        except (struct.error, UnicodeDecodeError, ValueError):
            return None
        self._layout, self._layout_values, self._names = layout, layout.unpack_from(data, _NAMES_AT), names
        n = len(names)
        at += -(at - 4) % 4  # the first column's count
        first = at + 4 + (-at % 8)  # its doubles (8-aligned relative to the payload, after the 4-byte header)
        rows_at = first - 8  # rows of n + 1 doubles from here: the slot before each column's doubles holds its count
        if n == 0 or rows_at + 8 * 5 * (n + 1) > len(data):
            return None
        # the first count, then each later one at the start of its row (a count, 4 bytes of padding, the doubles)
        counts = struct.Struct(f"<I{first - at - 4 + 8 * n}x" + f"I{4 + 8 * n}x" * 3 + "I")
        return _Rows(len(data), n, rows_at, counts, at, (n,) * 5)

    def _same_names(self, data: bytes) -> bool:
        layout = self._layout
        if layout is None or len(data) < _NAMES_AT + layout.size:
            return False
        return layout.unpack_from(data, _NAMES_AT) == self._layout_values

    def _read(self, data: bytes) -> Fields:
        if self._same_names(data):
            assert self._layout is not None
            names, at = self._names, _NAMES_AT + self._layout.size
        else:
            names, at, layout = _read_names(data)
            self._layout, self._layout_values, self._names = layout, layout.unpack_from(data, _NAMES_AT), names
            self._rows = None  # where block() found the columns held for the names before
        columns = []
        for _ in range(5):
            at += -(at - 4) % 4  # CDR aligns relative to the payload, after the 4-byte header
            (n,) = _U32.unpack_from(data, at)
            at += 4
            if n:
                at += -(at - 4) % 8
                if at + 8 * n > len(data):
                    raise ValueError("sequence runs past the message")
                columns.append(_doubles(n).unpack_from(data, at))
                at += 8 * n
            else:
                columns.append(())
        q, dq, tau, kp, kd = columns
        return names, q, dq, tau, kp, kd


def _read_names(data: bytes) -> tuple[tuple[str, ...], int, struct.Struct]:
    """The names, the offset just after them, and a struct that reads their count, then each name's length
    and bytes, skipping the padding before each length."""
    (count,) = _U32.unpack_from(data, _NAMES_AT)
    if count > len(data):
        raise ValueError("name count runs past the message")
    at = _NAMES_AT + 4
    names, parts = [], ["<I"]
    for _ in range(count):
        pad = -(at - 4) % 4
        at += pad
        (size,) = _U32.unpack_from(data, at)  # with its NUL
        at += 4
        if size == 0 or at + size > len(data):
            raise ValueError("string runs past the message")
        names.append(data[at : at + size - 1].decode())
        parts.append(f"{pad}xI{size}s" if pad else f"I{size}s")
        at += size
    return tuple(names), at, struct.Struct("".join(parts))
