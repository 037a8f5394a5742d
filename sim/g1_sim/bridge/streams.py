"""DDS topics of the simulated G1: rt/lowstate and rt/sportmodestate out, rt/lowcmd and rt/arm_sdk in."""

from __future__ import annotations

import logging
import threading
from collections import Counter
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber

from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.idl import LowCmd_, LowState_, SportModeState_
from g1_mode_manager.protocol.unitree_sdk_internals import (
    channel_datareader,
    channel_matched_readers,
    publisher_channel,
    subscriber_channel,
)
from g1_sim.bridge.arrivals import Arrivals, last_uint32
from g1_sim.bridge.commands import CommandIntake
from g1_sim.bridge.lowstate_codec import LowStatePacker, self_check

log = logging.getLogger(__name__)

#: Reader queue length of the command topics (the SDK's reader thread drops the oldest beyond it).
COMMAND_QUEUE_LEN = 4


class LowStateLike(Protocol):
    q: np.ndarray
    dq: np.ndarray
    tau_est: np.ndarray
    imu_quaternion: np.ndarray
    imu_gyroscope: np.ndarray
    imu_accelerometer: np.ndarray
    imu_rpy: np.ndarray
    tick: int


class StatePublishers:
    """Writers of rt/lowstate (packed without cyclonedds' slow serialiser) and rt/sportmodestate.

    ``publish_*`` are called from the sim thread only.
    """

    def __init__(self) -> None:
        self._lowstate = ChannelPublisher(topics.LOWSTATE, LowState_)
        self._lowstate.Init()
        self._sport = ChannelPublisher(topics.SPORTMODESTATE, SportModeState_)
        self._sport.Init()
        self._packer = LowStatePacker()
        self_check(self._packer)
        self._sport_msg = SportModeState_(fsm_id=0, fsm_mode=0, task_id=0, task_time=0.0)
        self._lock = threading.Lock()
        self._counts: Counter[str] = Counter()

    def publish_lowstate(self, s: LowStateLike) -> None:
        msg = self._packer.pack(s.q, s.dq, s.tau_est, s.imu_quaternion, s.imu_gyroscope, s.imu_accelerometer,
                                s.imu_rpy, s.tick)  # fmt: skip
        ok = self._lowstate.Write(msg)
        self._bump("lowstate" if ok else "lowstate_write_errors")

    def publish_sportmodestate(self, fsm_id: int, fsm_mode: int, task_id: int = 0, task_time: float = 0.0) -> None:
        """``task_id``/``task_time``: the built-in arm motion playing and its seconds so far (0, 0.0: none)."""
        self._sport_msg.fsm_id = fsm_id
        self._sport_msg.fsm_mode = fsm_mode
        self._sport_msg.task_id = task_id
        self._sport_msg.task_time = task_time
        ok = self._sport.Write(self._sport_msg)
        self._bump("sportmodestate" if ok else "sportmodestate_write_errors")

    def _bump(self, key: str) -> None:
        with self._lock:
            self._counts[key] += 1

    def counts(self) -> dict[str, int]:
        with self._lock:
            return dict(self._counts)

    def readers(self) -> dict[str, int]:
        """How many readers each state topic's writer has matched now: who receives it (-1: unknown)."""
        return {"lowstate": _matched_readers(self._lowstate), "sportmodestate": _matched_readers(self._sport)}


def _matched_readers(publisher: ChannelPublisher) -> int:
    """The publication-matched count the SDK's channel writer keeps (the SDK has no accessor)."""
    try:
        return int(channel_matched_readers(publisher_channel(publisher)))
    except AttributeError:
        return -1


class CommandSubscribers:
    """Readers of rt/lowcmd and rt/arm_sdk, feeding a CommandIntake."""

    def __init__(self, intake: CommandIntake, *, stamp_arrivals: bool = False) -> None:
        self._subs: list[Any] = []
        self._arrivals: dict[str, Arrivals] = {}
        for topic, handler in ((topics.LOWCMD, intake.on_lowcmd), (topics.ARM_SDK, intake.on_arm_sdk)):
            sub = ChannelSubscriber(topic, LowCmd_)
            sub.Init(_logged(topic, handler), COMMAND_QUEUE_LEN)
            self._subs.append(sub)
            if stamp_arrivals:  # for the sim's record: receive times where Cyclone delivers (arrivals.py)
                reader = channel_datareader(subscriber_channel(sub))
                stamps = Arrivals(reader, last_uint32, window=2 * COMMAND_QUEUE_LEN)
                self._arrivals[topic.removeprefix("rt/")] = stamps

    def arrival(self, topic: str, crc: int) -> float | None:
        """When the frame with this crc reached the process (``topic`` as the record names it), or None."""
        arrivals = self._arrivals.get(topic)
        return arrivals.pop(crc) if arrivals is not None else None


def _logged(topic: str, handler: Callable[[LowCmd_], object]) -> Callable[[LowCmd_], None]:
    """An exception would end the SDK's reader thread for good: log it and go on."""

    def run(msg: LowCmd_) -> None:
        try:
            handler(msg)
        except Exception:
            log.exception("frame on %s failed", topic)

    return run
