"""unitree_hg LowCmd_ frames held as flat values and published as ready-made CDR bytes.

cyclonedds-python's generic serialiser costs more per LowCmd_ (35 nested MotorCmd_) than the CRC
itself, and a 500 Hz lowcmd relay cannot afford that. A frame here is the C struct's field values in order; one
precompiled ``struct.Struct`` packs them for the CRC, and the CDR payload is the same bytes but for
the padding before the first motor (CDR aligns MotorCmd_ by its first member, a uint8). The writer
checks once, at creation, that its bytes equal cyclonedds' own serialisation, and otherwise falls
back to writing LowCmd_ objects.
"""

from __future__ import annotations

import logging
import math
import struct
from collections.abc import Callable, Sequence
from typing import Any, Final

from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.crc import crc32_words
from g1_mode_manager.protocol.cyclone_internals import write_serialized, writer_use_version_2
from g1_mode_manager.protocol.dds import sdk_participant
from g1_mode_manager.protocol.idl import LowCmd_, MotorCmd_
from g1_mode_manager.protocol.motors import NUM_MOTOR_SLOTS

_log = logging.getLogger(__name__)

_C_STRUCT: Final = struct.Struct("<2B2x" + "B3x5fI" * NUM_MOTOR_SLOTS + "5I")  # 1004 bytes, crc last
_CRC_END: Final = _C_STRUCT.size - 4
_PER_MOTOR: Final = 7  # mode, q, dq, tau, kp, kd, reserve
_MOTOR0: Final = 2  # index of motor 0's mode in the flat values


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


class LowCmdFrame:
    """One LowCmd_ as its field values in C struct order (every motor disabled at first). Not thread-safe."""

    def __init__(self) -> None:
        self.values: list[int | float] = [0, 0] + [0, 0.0, 0.0, 0.0, 0.0, 0.0, 0] * NUM_MOTOR_SLOTS + [0] * 5

    def set_header(self, mode_pr: int, mode_machine: int) -> None:
        self.values[0], self.values[1] = int(mode_pr), int(mode_machine)

    def set_motor(self, index: int, mode: int, command: MotorCommand) -> None:
        k = _MOTOR0 + _PER_MOTOR * index
        self.values[k : k + 6] = (int(mode), float(command.q), float(command.dq), float(command.tau),
                                  float(command.kp), float(command.kd))  # fmt: skip

    def set_q(self, index: int, q: float) -> None:
        self.values[_MOTOR0 + _PER_MOTOR * index + 1] = float(q)

    def pack(self) -> tuple[bytes, int]:
        """(the C struct's bytes up to the crc, the crc)."""
        packed = _C_STRUCT.pack(*self.values)[:_CRC_END]
        return packed, crc32_words(packed)

    def cdr(self, header: bytes) -> bytes:
        """The serialised sample: encapsulation ``header``, the fields, the crc."""
        c, crc = self.pack()
        return b"".join((header, c[:2], c[4:5], b"\0", c[8:], crc.to_bytes(4, "little")))

    def to_message(self) -> LowCmd_:
        """The same frame as a LowCmd_ (crc set), for the SDK's APIs and for checks."""
        v = self.values
        motors = [MotorCmd_(*v[k : k + _PER_MOTOR]) for k in range(_MOTOR0, _MOTOR0 + _PER_MOTOR * NUM_MOTOR_SLOTS,
                                                                      _PER_MOTOR)]  # fmt: skip
        return LowCmd_(mode_pr=v[0], mode_machine=v[1], motor_cmd=motors, reserve=list(v[-5:-1]), crc=self.pack()[1])


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
            probe.values[-2] = 7  # reserve[3]
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

    def write(self, frame: LowCmdFrame) -> bool:
        """Publish ``frame`` (crc computed here); False if DDS refused it."""
        try:
            if self._raw is not None:
                return self._raw(self._writer, frame.cdr(self._header))
            self._writer.write(frame.to_message())
            return True
        except Exception:
            _log.exception("write on %s failed", self.topic)
            return False

    def close(self) -> None:
        self._raw = None
        self._writer = None
