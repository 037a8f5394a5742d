"""Readers of the robot's state topics that cost nothing per sample in Python.

The robot publishes rt/lowstate at 500 Hz. A Python listener per sample (GIL, ctypes callback, decode)
costs a noticeable share of a core on its own at that rate; here Cyclone keeps only the newest sample (KEEP_LAST 1, in C) and a
reader takes it when someone asks (``latest()``, ``age_s()``...), decoding only then. "Received" is
the moment a read found a new sample: it errs late by at most the gap between reads, which the
node's supervisor keeps at or below 0.1 s (and any active relay far below). A per-sample callback is
installed only while a listener is set (``set_listener``).
"""

from __future__ import annotations

import logging
import struct
import threading
import time
from collections.abc import Callable
from typing import Any, Final, Generic, TypeVar

from cyclonedds.core import Listener
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from g1_mode_manager.core.port import SportState
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.cyclone_internals import delete_entity, take_serialized
from g1_mode_manager.protocol.dds import sdk_participant
from g1_mode_manager.protocol.idl import LowState_, SportModeState_
from g1_mode_manager.protocol.motors import NUM_JOINTS

T = TypeVar("T")
_log = logging.getLogger(__name__)


#: Cyclone keeps only the newest sample; best effort: a lost state sample is superseded 2 ms later, and
#: acknowledging 500 samples/s would cost CPU for nothing.
LATEST_ONLY_QOS: Final = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1))


#: Reads closer together than this reuse the last one: "received" errs late by at most this much more, s.
READ_GAP_S: Final = 0.002


class LatestSample(Generic[T]):
    """The newest sample of one topic, taken when asked for and decoded once; its receive time and a count.

    Thread-safe: a read takes from Cyclone and updates (sample, receive time, count) under one lock, so
    every reader sees one consistent triple.
    """

    def __init__(self, topic: str, msg_type: type, decode: Callable[[bytes], T],
                 on_sample: Callable[[T], None] | None = None) -> None:
        participant = sdk_participant()
        self.topic = topic
        self._decode = decode
        self._lock = threading.Lock()
        self._sample: T | None = None
        self._stamp = 0.0
        self._published = float("nan")  # when the robot published it (its DDS source timestamp), monotonic s
        self._count = 0
        self._read_at = float("-inf")
        self._errors = 0
        self._callback: Callable[[T], None] | None = None
        self._listener_lock = threading.Lock()
        self._listeners: list[Listener] = []  # never freed while we live: cyclonedds may call a freed one
        self._participant = participant
        self._topic = Topic(participant, topic, msg_type)
        self._closed = False
        self._reader: DataReader | None = DataReader(participant, self._topic, qos=LATEST_ONLY_QOS)
        if on_sample is not None:
            self.set_listener(on_sample)

    def _read_locked(self) -> T | None:
        """Take what Cyclone holds (the newest sample, if one came since the last read); the new one or None."""
        reader = self._reader
        if reader is None:
            return None
        try:
            taken = take_serialized(reader, 4)
            data = [(d, info.source_timestamp) for d, info in taken if info.valid_data]
            if not data:
                return None
            sample = self._decode(data[-1][0])
        except Exception:
            self._errors += 1
            if self._errors == 1:
                _log.exception("bad sample on %s", self.topic)
            return None
        self._on_new(self._sample, sample)
        now = time.monotonic()
        self._sample, self._stamp, self._count = sample, now, self._count + len(data)
        # the writer's CLOCK_REALTIME as this process's monotonic clock: on one machine (the sim) the moment the
        # robot published it; a robot's own clock adds its offset from this machine's
        self._published = data[-1][1] * 1e-9 - (time.time() - now)
        return sample

    def _on_new(self, previous: T | None, sample: T) -> None:
        """Hook under the lock when a read found a new sample."""

    def latest(self) -> tuple[T | None, float, int]:
        """(sample or None, its monotonic receive time, samples read so far).

        Reads Cyclone at most once per READ_GAP_S: one forwarded frame asks several times (link health,
        mode_machine), and a 500 Hz stream would otherwise be taken and decoded for each of them.
        """
        with self._lock:
            self._refresh_locked()
            return self._sample, self._stamp, self._count

    def latest_published(self) -> tuple[T | None, float, float]:
        """(sample or None, its monotonic receive time, when it was published: see ``_read_locked``), consistent."""
        with self._lock:
            self._refresh_locked()
            return self._sample, self._stamp, self._published

    def _refresh_locked(self) -> None:
        now = time.monotonic()
        if now - self._read_at >= READ_GAP_S:
            self._read_at = now
            self._read_locked()

    @property
    def count(self) -> int:
        """Samples read so far: it changes when, and only when, a newer sample is there."""
        return self.latest()[2]

    def age_s(self) -> float | None:
        sample, stamp, _ = self.latest()
        return None if sample is None else time.monotonic() - stamp

    def set_listener(self, callback: Callable[[T], None] | None) -> None:
        """Call ``callback`` with every new sample in Cyclone's receive thread (keep it short); None removes it.

        A Python call per sample: only for who needs every sample (tests, a per-sample mirror).
        """
        with self._listener_lock:  # not self._lock: Cyclone waits for a running callback, which takes that one
            self._callback = callback
            reader = self._reader
            if reader is None:
                return
            if callback is None:
                reader.set_listener(None)
                return
            listener = Listener(on_data_available=self._on_data)
            self._listeners.append(listener)
            reader.set_listener(listener)

    def _on_data(self, _reader: Any) -> None:
        with self._lock:
            sample = self._read_locked()
        callback = self._callback
        if sample is not None and callback is not None:
            try:
                callback(sample)
            except Exception:  # a faulty callback must not kill the DDS receive thread
                _log.exception("callback for %s failed", self.topic)

    @property
    def receiving(self) -> bool:
        """True while subscribed (see set_receiving)."""
        return self._reader is not None

    def set_receiving(self, on: bool) -> None:
        """Subscribe (``True``) or unsubscribe: while off, the robot sends this process nothing on the topic
        and Cyclone spends nothing on it; the last sample stays readable. Back on, samples flow again as
        soon as the writer matched the new reader (a few ms on loopback)."""
        with self._listener_lock, self._lock:
            if self._closed or on == (self._reader is not None):
                return
            if on:
                self._reader = DataReader(self._participant, self._topic, qos=LATEST_ONLY_QOS)
                if self._callback is not None:
                    listener = Listener(on_data_available=self._on_data)
                    self._listeners.append(listener)
                    self._reader.set_listener(listener)
                return
            reader, self._reader = self._reader, None
        if reader is not None:
            delete_entity(reader)  # now: cyclonedds would delete it only when the object is collected

    def close(self) -> None:
        self.set_listener(None)
        with self._lock:
            self._closed = True
            self._reader = None


class LowStateSnapshot:
    """What the node needs of one rt/lowstate, decoded straight from the wire; ``message()`` for the rest.

    The joint positions are decoded on first use only: at 500 Hz most samples are read for their
    mode_machine and tick alone (link health, frames).
    """

    __slots__ = ("_q", "data", "mode_machine", "tick")

    def __init__(self, mode_machine: int, tick: int, data: bytes, q: tuple[float, ...] | None = None) -> None:
        self.mode_machine = mode_machine
        self.tick = tick
        self.data = data  # the serialised sample
        self._q = q

    @property
    def q(self) -> tuple[float, ...]:
        """The 29 joint positions in motor order."""
        if self._q is None:
            self._q = _Q.unpack_from(self.data, _Q_AT)
        return self._q

    def message(self) -> LowState_:
        return LowState_.deserialize(self.data)


# CDR offsets in a LowState_ sample after the 4-byte encapsulation header (checked against cyclonedds by a
# test): MotorState_ is aligned by its first member, a uint8, so motor 0 starts right after the IMU's int16.
_MODE_MACHINE_AT: Final = 4 + 9
_TICK: Final = struct.Struct("<I")
_TICK_AT: Final = 4 + 12
_Q: Final = struct.Struct("<" + "f52x" * (NUM_JOINTS - 1) + "f")  # q of motors 0..28, 56 bytes apart
_Q_AT: Final = 4 + 72
_LITTLE_ENDIAN_ENCODINGS: Final = (0x01, 0x07)  # CDR_LE (XCDR1), PLAIN_CDR2_LE: same layout for this type


def decode_lowstate(data: bytes) -> LowStateSnapshot:
    """Decode mode_machine, tick and the 29 joint positions of a serialised LowState_ by struct (a full
    deserialisation costs far more, too much at 500 Hz)."""
    if data[0] == 0 and data[1] in _LITTLE_ENDIAN_ENCODINGS and len(data) >= _Q_AT + _Q.size:
        return LowStateSnapshot(mode_machine=data[_MODE_MACHINE_AT], tick=_TICK.unpack_from(data, _TICK_AT)[0],
                                data=data)
    msg = LowState_.deserialize(data)
    return LowStateSnapshot(mode_machine=int(msg.mode_machine), tick=int(msg.tick),
                            q=tuple(float(m.q) for m in msg.motor_state[:NUM_JOINTS]), data=data)


#: A measured pose older than this is not handed out (the robot moves; 500 Hz gives ~2 ms old ones).
FRESH_POSE_S = 0.1
#: rt/lowstate's tick (ms) going back by more than this means the robot restarted (not reordering, not
#: the uint32 wrap after 49 days, which goes back by almost 2**32).
TICK_RESTART_MS = 1000


class LowStateReader(LatestSample[LowStateSnapshot]):
    """rt/lowstate (500 Hz on the robot): mode_machine for LowCmd_, the measured joint positions, reboots.

    Decodes only what the node needs, and only when it asks (see the module docstring).
    """

    def __init__(self, topic: str = topics.LOWSTATE) -> None:
        self._restarts = 0
        super().__init__(topic, LowState_, decode_lowstate)

    def _on_new(self, previous: LowStateSnapshot | None, sample: LowStateSnapshot) -> None:
        if previous is not None and sample.tick + TICK_RESTART_MS < previous.tick:
            self._restarts += 1  # the robot's tick went back: it rebooted

    @property
    def restarts(self) -> int:
        """How often the robot's tick went back (a reboot) since this reader started."""
        with self._lock:
            self._read_locked()
            return self._restarts

    @property
    def mode_machine(self) -> int | None:
        snapshot, _, _ = self.latest()
        return None if snapshot is None else snapshot.mode_machine

    def joint_positions(self, max_age_s: float = FRESH_POSE_S) -> tuple[float, ...] | None:
        """The measured pose, only while it is current: None when unsubscribed or older than ``max_age_s``."""
        snapshot, stamp, _ = self.latest()
        if snapshot is None or self._reader is None or time.monotonic() - stamp > max_age_s:
            return None
        return snapshot.q


_SPORT: Final = struct.Struct("<IIIf")  # fsm_id, fsm_mode, task_id (uint32), task_time (float32)


def decode_sport_state(data: bytes) -> SportModeState_:
    """A serialised SportModeState_ by struct (far cheaper than cyclonedds' deserialiser); other encodings the slow way."""
    if data[0] == 0 and data[1] in _LITTLE_ENDIAN_ENCODINGS and len(data) >= 4 + _SPORT.size:
        return SportModeState_(*_SPORT.unpack_from(data, 4))
    return SportModeState_.deserialize(data)


class SportStateReader(LatestSample[SportModeState_]):
    """rt/sportmodestate (the loco controller's fsm id and mode), read when asked.

    ``on_sample`` (or ``set_listener``) runs in the DDS receive thread for every sample: keep it short.
    """

    def __init__(self, on_sample: Callable[[SportModeState_], None] | None = None) -> None:
        super().__init__(topics.SPORTMODESTATE, SportModeState_, decode_sport_state, on_sample)

    def state(self) -> SportState | None:
        sample, stamp, _ = self.latest()
        if sample is None:
            return None
        return SportState(fsm_id=int(sample.fsm_id), fsm_mode=int(sample.fsm_mode), task_id=int(sample.task_id),
                          task_time=float(sample.task_time), age_s=time.monotonic() - stamp)
