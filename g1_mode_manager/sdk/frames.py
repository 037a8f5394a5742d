"""unitree_hg LowCmd_ frames held as their C struct in a numpy buffer and published as ready-made CDR bytes.

cyclonedds-python's generic serialiser costs more per LowCmd_ (35 nested MotorCmd_) than the CRC
itself, and a 500 Hz lowcmd relay cannot afford that, nor a Python call per motor. A frame here is the
C struct itself: joint columns go in with one numpy assignment per field, the robot's CRC runs over it
in C (numpy, zlib), and the CDR payload is the same bytes but for the padding before the first motor (CDR
aligns MotorCmd_ by its first member, a uint8). The writer checks once, at creation, that its bytes
equal cyclonedds' own serialisation, and otherwise falls back to writing LowCmd_ objects.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import Any, Final

import numpy as np

from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.crc import crc32_of_array, crc32_words
from g1_mode_manager.protocol.cyclone_internals import write_serialized, writer_use_version_2
from g1_mode_manager.protocol.dds import sdk_participant
from g1_mode_manager.protocol.idl import LowCmd_, MotorCmd_
from g1_mode_manager.protocol.motors import NUM_MOTOR_SLOTS

_log = logging.getLogger(__name__)

#: The C struct LowCmd_ (1004 bytes, crc last): what the robot's CRC runs over (all but the crc word).
_MOTOR_DTYPE: Final = np.dtype([("mode", "u1"), ("_pad", "u1", (3,)), ("q", "<f4"), ("dq", "<f4"), ("tau", "<f4"),
                                ("kp", "<f4"), ("kd", "<f4"), ("reserve", "<u4")])
_C_DTYPE: Final = np.dtype([("mode_pr", "u1"), ("mode_machine", "u1"), ("_pad", "u1", (2,)),
                            ("motor", _MOTOR_DTYPE, (NUM_MOTOR_SLOTS,)), ("reserve", "<u4", (4,)), ("crc", "<u4")])
_CRC_END: Final = _C_DTYPE.itemsize - 4
_MOTORS_AT: Final = _C_DTYPE.fields["motor"][1]
_CRC_WORDS: Final = _CRC_END // 4
_FIELDS: Final = ("q", "dq", "tau", "kp", "kd")


def check_commands(frame: str, commands: Sequence[MotorCommand], expected: int) -> None:
    """ValueError unless there are ``expected`` commands, all finite, with gains >= 0 (never send NaN)."""
    if len(commands) != expected:
        raise ValueError(f"{frame}: expected {expected} motor commands, got {len(commands)}")
    for i, c in enumerate(commands):
        values = (c.q, c.dq, c.tau, c.kp, c.kd)
        if not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in values):
            raise ValueError(f"{frame}: command {i} has a non-finite value: {c}")
        if c.kp < 0 or c.kd < 0:
            raise ValueError(f"{frame}: command {i} has a negative gain: {c}")


def check_block(frame: str, block: np.ndarray) -> None:
    """``check_columns`` over the five columns as one 5 x n array (q, dq, tau, kp, kd)."""
    if not np.isfinite(block).all():
        raise ValueError(f"{frame}: a command has a non-finite value")
    if block.shape[1] and block[3:].min() < 0:
        raise ValueError(f"{frame}: a command has a negative gain")


def check_columns(frame: str, q: Sequence[float], dq: Sequence[float], tau: Sequence[float], kp: Sequence[float],
                  kd: Sequence[float]) -> None:
    """The same check over columns of floats, whole columns at a time (C builtins: cheap at 500 Hz)."""
    if not all(all(map(math.isfinite, c)) for c in (q, dq, tau, kp, kd)):
        raise ValueError(f"{frame}: a command has a non-finite value")
    if (kp and min(kp) < 0) or (kd and min(kd) < 0):
        raise ValueError(f"{frame}: a command has a negative gain")


@lru_cache(maxsize=64)
def _index_array(indices: tuple[int, ...]) -> np.ndarray | slice:
    """Where a frame's columns go: a slice for the usual 0..n-1 in order (cheapest), else an index array."""
    if indices == tuple(range(len(indices))):
        return slice(0, len(indices))
    return np.array(indices, dtype=np.intp)


class LowCmdFrame:
    """One LowCmd_ as its C struct in a numpy buffer (every motor disabled at first). Not thread-safe.

    Columns of joint values go in with one numpy assignment per field; the CRC runs over the buffer in
    place; the CDR payload is the same bytes but for the padding before the first motor.
    """

    def __init__(self) -> None:
        self._buf = np.zeros(1, dtype=_C_DTYPE)
        record = self._buf[0]
        self._motor = record["motor"]
        self._columns = {f: self._motor[f] for f in _FIELDS}
        self._mode = self._motor["mode"]
        self._bytes = self._buf.view(np.uint8)
        self._words = self._buf.view("<u4").reshape(-1)  # the crc is the last word
        # each motor as 7 words, q..kd the 2nd to 6th: five columns go in with one assignment
        self._motor_words = self._bytes[_MOTORS_AT:_MOTORS_AT + _MOTOR_DTYPE.itemsize * NUM_MOTOR_SLOTS].view(
            "<f4").reshape(NUM_MOTOR_SLOTS, _MOTOR_DTYPE.itemsize // 4)
        self._header = (0, 0)

    def set_header(self, mode_pr: int, mode_machine: int) -> None:
        header = (int(mode_pr), int(mode_machine))
        if header != self._header:  # the same for every frame of a stream: two structured writes saved
            self._buf["mode_pr"], self._buf["mode_machine"] = header
            self._header = header

    def set_motor(self, index: int, mode: int, command: MotorCommand) -> None:
        self._motor[index] = (int(mode), (0, 0, 0), float(command.q), float(command.dq), float(command.tau),
                              float(command.kp), float(command.kd), self._motor[index]["reserve"])

    def set_columns(self, indices: tuple[int, ...], mode: int, columns: Sequence[Sequence[float]]) -> None:
        """Motors ``indices`` get ``mode`` and the five columns (q, dq, tau, kp, kd), in that order."""
        where = _index_array(indices)
        self._mode[where] = mode
        for field, values in zip(_FIELDS, columns, strict=True):
            self._columns[field][where] = values

    def set_block(self, indices: tuple[int, ...], mode: int, block: np.ndarray) -> None:
        """``set_columns`` with the five columns as one 5 x len(indices) array."""
        where = _index_array(indices)
        self._mode[where] = mode
        self._motor_words[where, 1:6] = block.T

    def set_all(self, count: int, mode: int, command: MotorCommand) -> None:
        """Motors 0..count-1 all get ``mode`` and ``command``."""
        self._mode[:count] = mode
        for field in _FIELDS:
            self._columns[field][:count] = getattr(command, field)

    def set_q(self, index: int, q: float) -> None:
        self._columns["q"][index] = float(q)

    def set_reserve(self, index: int, value: int) -> None:
        self._buf["reserve"][0, index] = int(value)

    def pack(self) -> tuple[bytes, int]:
        """(the C struct's bytes up to the crc, the crc)."""
        packed = self._bytes[:_CRC_END].tobytes()
        return packed, crc32_words(packed)

    def cdr(self, header: bytes) -> bytes:
        """The serialised sample: encapsulation ``header``, the fields, the crc."""
        self._words[_CRC_WORDS] = crc32_of_array(self._buf, _CRC_WORDS)
        c = self._bytes.tobytes()
        return b"".join((header, c[:2], c[4:5], b"\0", c[8:]))

    def to_message(self) -> LowCmd_:
        """The same frame as a LowCmd_ (crc set), for the SDK's APIs and for checks."""
        m = self._motor
        motors = [MotorCmd_(int(m["mode"][i]), *(float(m[f][i]) for f in _FIELDS), int(m["reserve"][i]))
                  for i in range(NUM_MOTOR_SLOTS)]
        return LowCmd_(mode_pr=int(self._buf["mode_pr"][0]), mode_machine=int(self._buf["mode_machine"][0]),
                       motor_cmd=motors, reserve=[int(v) for v in self._buf["reserve"][0]],
                       crc=self.pack()[1])


class FrameWriter:
    """A DDS writer of LowCmd_ on one topic, on the SDK's participant, sending LowCmdFrame bytes directly.

    No 0.2 s sleep (the SDK's writer sleeps for discovery; a stream's first frames may be missed either way).
    """

    def __init__(self, topic: str) -> None:
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        participant = sdk_participant()
        self.topic = topic
        self._writer = DataWriter(participant, Topic(participant, topic, LowCmd_))
        self._raw = self._raw_write_function()

    def _raw_write_function(self) -> Callable[[Any, bytes], bool] | None:
        """cyclonedds' write of ready-made bytes, with our header, if our bytes equal its serialisation; else None."""
        try:
            probe = LowCmdFrame()
            probe.set_header(0, 5)
            probe.set_motor(3, 1, MotorCommand(q=0.5, dq=-1.0, tau=2.0, kp=40.0, kd=1.0))
            probe.set_reserve(3, 7)
            expected = probe.to_message().serialize(use_version_2=writer_use_version_2(self._writer))
            self._header = expected[:4]
            if probe.cdr(self._header) == expected:
                return write_serialized
        except Exception:  # an incompatible cyclonedds: use the slow, public path
            _log.exception("raw LowCmd_ writing unavailable")
        _log.warning("writing %s through cyclonedds' serialiser (~0.5 ms a frame)", self.topic)
        return None

    @property
    def fast(self) -> bool:
        return self._raw is not None

    def serialize(self, frame: LowCmdFrame) -> bytes | LowCmd_:
        """``frame`` as this writer sends it (crc computed here), to be sent any number of times by
        ``write_bytes``: a frame that never changes is made once."""
        return frame.cdr(self._header) if self._raw is not None else frame.to_message()

    def write(self, frame: LowCmdFrame) -> bool:
        """Publish ``frame`` (crc computed here); False if DDS refused it."""
        try:
            return self.write_bytes(self.serialize(frame))
        except Exception:
            _log.exception("write on %s failed", self.topic)
            return False

    def write_bytes(self, data: bytes | LowCmd_) -> bool:
        """Publish what ``serialize`` made; False if DDS refused it."""
        try:
            if self._raw is not None and isinstance(data, bytes):
                return self._raw(self._writer, data)
            self._writer.write(data)
            return True
        except Exception:
            _log.exception("write on %s failed", self.topic)
            return False

    def close(self) -> None:
        self._raw = None
        self._writer = None
