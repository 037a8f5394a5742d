"""Subscribers to the robot's state topics that keep the latest sample and when it arrived.

Handlers run in Cyclone's listener thread (no queue: the latest sample is all we need, and a queue
would add a thread and latency); they only swap a reference under a lock, so readers in other
threads always see one consistent (sample, receive time, count) triple.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

from unitree_sdk2py.core.channel import ChannelSubscriber

from g1_mode_manager.core.port import SportState
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.idl import LowState_, SportModeState_
from g1_mode_manager.protocol.motors import NUM_JOINTS

T = TypeVar("T")
_log = logging.getLogger(__name__)


class LatestSample(Generic[T]):
    """Latest sample of one topic with its monotonic receive time and a count, thread-safe."""

    def __init__(self, topic: str, msg_type: type[T], on_sample: Callable[[T], None] | None = None) -> None:
        self.topic = topic
        self._lock = threading.Lock()
        self._sample: T | None = None
        self._stamp = 0.0
        self._count = 0
        self._on_sample = on_sample
        self._subscriber = ChannelSubscriber(topic, msg_type)
        self._subscriber.Init(self._handle, 0)

    def _handle(self, sample: T) -> None:
        now = time.monotonic()
        with self._lock:
            self._sample, self._stamp, self._count = sample, now, self._count + 1
        callback = self._on_sample
        if callback is not None:
            try:
                callback(sample)
            except Exception:  # a faulty callback must not kill the DDS listener thread
                _log.exception("callback for %s failed", self.topic)

    def latest(self) -> tuple[T | None, float, int]:
        """(sample or None, its monotonic receive time, samples received so far)."""
        with self._lock:
            return self._sample, self._stamp, self._count

    @property
    def count(self) -> int:
        with self._lock:
            return self._count

    def age_s(self) -> float | None:
        sample, stamp, _ = self.latest()
        return None if sample is None else time.monotonic() - stamp

    def close(self) -> None:
        self._on_sample = None
        self._subscriber.Close()


class LowStateReader(LatestSample[LowState_]):
    """rt/lowstate (500 Hz on the robot): mode_machine for LowCmd_ and the measured joint positions."""

    def __init__(self, on_sample: Callable[[LowState_], None] | None = None) -> None:
        super().__init__(topics.LOWSTATE, LowState_, on_sample)

    @property
    def mode_machine(self) -> int | None:
        sample, _, _ = self.latest()
        return None if sample is None else int(sample.mode_machine)

    def joint_positions(self) -> tuple[float, ...] | None:
        sample, _, _ = self.latest()
        return None if sample is None else tuple(m.q for m in sample.motor_state[:NUM_JOINTS])


class SportStateReader(LatestSample[SportModeState_]):
    """rt/sportmodestate (the loco controller's fsm id and mode); ``on_sample`` lets the node mirror it.

    ``on_sample`` runs in the DDS listener thread: keep it short (e.g. hand off to a ROS publisher).
    """

    def __init__(self, on_sample: Callable[[SportModeState_], None] | None = None) -> None:
        super().__init__(topics.SPORTMODESTATE, SportModeState_, on_sample)

    def state(self) -> SportState | None:
        sample, stamp, _ = self.latest()
        if sample is None:
            return None
        return SportState(fsm_id=int(sample.fsm_id), fsm_mode=int(sample.fsm_mode), task_id=int(sample.task_id),
                          task_time=float(sample.task_time), age_s=time.monotonic() - stamp)  # fmt: skip
