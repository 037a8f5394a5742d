"""DDS topics of the simulated G1: rt/lowstate, rt/lf/lowstate, rt/sportmodestate, rt/lf/bmsstate,
rt/secondary_imu, rt/odommodestate and rt/lf/odommodestate out, rt/lowcmd, rt/user_lowcmd and rt/arm_sdk in."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
from unitree_sdk2py.core.channel import ChannelPublisher
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__BmsState_

from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.cyclone_internals import write_serialized, writer_use_version_2
from g1_mode_manager.protocol.idl import BmsState_, IMUState_, LowState_, OdomModeState_, SportModeState_
from g1_mode_manager.protocol.odom_fields import OdomFields, encode_odom
from g1_mode_manager.protocol.side_by_side import side_by_side
from g1_mode_manager.protocol.unitree_sdk_internals import (
    channel_datawriter,
    channel_matched_readers,
    publisher_channel,
)
from g1_sim.bridge import imu_codec
from g1_sim.bridge.body_report import BodyReport
from g1_sim.bridge.commands import CommandIntake
from g1_sim.bridge.frame_reader import FrameReader
from g1_sim.bridge.lowstate_codec import LowStatePacker, self_check
from g1_sim.physics.battery import CELLS

#: BmsState_ fields the sim has no model for: plausible constants (firmware version, health, cycles).
BMS_VERSION = (1, 0)
BMS_SOH = 100
BMS_CYCLE = 12
#: BmsState_.temperature entries the sim fills (deg C); the rest stay 0.
BMS_TEMPERATURES_C = (28, 28, 27, 27)
#: IMUState_.temperature of the torso IMU: no model, 0 like rt/lowstate's IMU.
TORSO_IMU_TEMPERATURE_C = 0


class LowStateLike(Protocol):
    q: np.ndarray
    dq: np.ndarray
    tau_est: np.ndarray
    imu_quaternion: np.ndarray
    imu_gyroscope: np.ndarray
    imu_accelerometer: np.ndarray
    imu_rpy: np.ndarray
    tick: int
    motor_mode: np.ndarray


Vec3 = tuple[float, float, float]


class OdomLike(Protocol):
    position: Vec3
    velocity: Vec3
    yaw_speed: float
    quaternion: tuple[float, float, float, float]
    gyroscope: Vec3
    rpy: Vec3
    body_height: float


class ImuLike(Protocol):
    quaternion: tuple[float, ...]
    gyroscope: tuple[float, ...]
    accelerometer: tuple[float, ...]
    rpy: tuple[float, ...]


class RawWriter:
    """One topic written as ready-made CDR bytes (XCDR1): an SDK publisher (discovery, its matched count) and
    its DataWriter.

    A sample no reader has matched is not handed to DDS: with the SDK's default QoS (volatile durability)
    DDS would drop it, and in the sim loop the call costs 7-10 us even then, 1000 times a second.
    """

    def __init__(self, topic: str, msg_type: type) -> None:
        self.publisher = ChannelPublisher(topic, msg_type)
        self.publisher.Init()
        self._channel = publisher_channel(self.publisher)
        self._writer = channel_datawriter(self._channel)
        if writer_use_version_2(self._writer):
            raise RuntimeError(f"the {topic} writer serialises XCDR2; its ready-made samples are XCDR1")

    def has_readers(self) -> bool:
        """Some reader has matched (the SDK's listener's count): a sample written now reaches someone."""
        return channel_matched_readers(self._channel) > 0

    def write(self, data: bytes) -> bool:
        """Publish one sample (encapsulation header first); False if DDS refused it."""
        if channel_matched_readers(self._channel) == 0:
            return True
        return write_serialized(self._writer, data)


def _publisher(topic: str, msg_type: type) -> ChannelPublisher:
    publisher = ChannelPublisher(topic, msg_type)
    publisher.Init()
    return publisher


class StatePublishers:
    """Writers of rt/lowstate and rt/lf/lowstate (packed without cyclonedds' slow serialiser),
    rt/sportmodestate, rt/lf/bmsstate, rt/secondary_imu and both odometry topics (written as ready-made bytes).

    ``publish_*`` and ``count_unread`` are called from the sim thread only. The loop asks ``wants_*`` before it
    computes a sample: one of a topic no reader has matched is counted as published (``count_unread``) but neither
    computed, packed nor handed to DDS, which would drop it (volatile durability). The sim runs much of its time
    with nobody on rt/lowstate, rt/secondary_imu or the odometry, and their 500 Hz work was a good part of its CPU.
    """

    def __init__(self) -> None:
        # the SDK's writers sleep 0.2 s each after their creation: side by side, once
        self._lowstate, self._lf_lowstate, self._sport, self._bms, self._imu, self._odom, self._lf_odom = side_by_side(
            lambda: _publisher(topics.LOWSTATE, LowState_), lambda: _publisher(topics.LF_LOWSTATE, LowState_),
            lambda: _publisher(topics.SPORTMODESTATE, SportModeState_), lambda: _publisher(topics.LF_BMSSTATE, BmsState_),
            lambda: RawWriter(topics.SECONDARY_IMU, IMUState_), lambda: RawWriter(topics.ODOMMODESTATE, OdomModeState_),
            lambda: RawWriter(topics.LF_ODOMMODESTATE, OdomModeState_))
        self._bms_msg = unitree_hg_msg_dds__BmsState_()
        self._bms_msg.version_high, self._bms_msg.version_low = BMS_VERSION
        self._bms_msg.soh, self._bms_msg.cycle = BMS_SOH, BMS_CYCLE
        self._bms_msg.temperature[: len(BMS_TEMPERATURES_C)] = BMS_TEMPERATURES_C
        self._packer = LowStatePacker()
        self_check(self._packer)
        imu_codec.self_check()
        self._sport_msg = SportModeState_(fsm_id=0, fsm_mode=0, task_id=0, task_time=0.0)
        self._low_channel = publisher_channel(self._lowstate)
        self._lf_low_channel = publisher_channel(self._lf_lowstate)
        # written by the sim thread only; counts() copies it in one C call under the GIL
        self._counts: dict[str, int] = {}

    def publish_lowstate(self, s: LowStateLike, body: BodyReport, *, also_lf: bool = False) -> None:
        """rt/lowstate, and the same frame on rt/lf/lowstate if ``also_lf`` (the robot's decimated copy).

        Every motor's ``vol`` is the battery pack's voltage: the motors hang on the pack's bus."""
        msg = self._packer.pack(s.q, s.dq, s.tau_est, s.imu_quaternion, s.imu_gyroscope, s.imu_accelerometer,
                                s.imu_rpy, s.tick, body.temperature, body.remote, s.motor_mode,
                                body.battery.pack_v)
        ok = self._lowstate.Write(msg)
        self._bump("lowstate" if ok else "lowstate_write_errors")
        if also_lf:
            ok = self._lf_lowstate.Write(msg)
            self._bump("lf_lowstate" if ok else "lf_lowstate_write_errors")

    def count_unread(self, topic: str, *, also_lf: bool = False) -> None:
        """Count a sample of ``topic`` (lowstate, secondary_imu, odommodestate) the robot published to nobody."""
        self._bump(topic)
        if also_lf:
            self._bump("lf_" + topic)

    def wants_lowstate(self, *, also_lf: bool = False) -> bool:
        return channel_matched_readers(self._low_channel) > 0 or (
            also_lf and channel_matched_readers(self._lf_low_channel) > 0)

    def wants_secondary_imu(self) -> bool:
        return self._imu.has_readers()

    def wants_odom(self, *, also_lf: bool = False) -> bool:
        return self._odom.has_readers() or (also_lf and self._lf_odom.has_readers())

    def publish_secondary_imu(self, imu: ImuLike) -> None:
        """rt/secondary_imu: the torso IMU (unitree_hg IMUState_)."""
        data = imu_codec.encode_imu(imu.quaternion, imu.gyroscope, imu.accelerometer, imu.rpy, TORSO_IMU_TEMPERATURE_C)
        ok = self._imu.write(data)
        self._bump("secondary_imu" if ok else "secondary_imu_write_errors")

    def publish_odom(self, stamp_s: float, o: OdomLike, *, also_lf: bool = False) -> None:
        """rt/odommodestate (unitree_go SportModeState_, stamped with sim time), and the same sample on
        rt/lf/odommodestate if ``also_lf``."""
        data = encode_odom(OdomFields(stamp_s=stamp_s, position=o.position, velocity=o.velocity, yaw_speed=o.yaw_speed,
                                      quaternion=o.quaternion, gyroscope=o.gyroscope, rpy=o.rpy,
                                      body_height=o.body_height))
        ok = self._odom.write(data)
        self._bump("odommodestate" if ok else "odommodestate_write_errors")
        if also_lf:
            ok = self._lf_odom.write(data)
            self._bump("lf_odommodestate" if ok else "lf_odommodestate_write_errors")

    def publish_bmsstate(self, body: BodyReport) -> None:
        """rt/lf/bmsstate: soc %, pack voltage (mV, bmsvoltage[0]), the 13 cells (mV), current (mA)."""
        b, m = body.battery, self._bms_msg
        m.soc = round(b.soc)
        m.bmsvoltage[0] = round(b.pack_v * 1000.0)
        m.cell_vol[:CELLS] = [round(b.cell_v * 1000.0)] * CELLS
        m.current = round(b.current_a * 1000.0)
        ok = self._bms.Write(m)
        self._bump("bmsstate" if ok else "bmsstate_write_errors")

    def publish_sportmodestate(self, fsm_id: int, fsm_mode: int, task_id: int = 0, task_time: float = 0.0) -> None:
        """``task_id``/``task_time``: the built-in arm motion playing and its seconds so far (0, 0.0: none)."""
        self._sport_msg.fsm_id = fsm_id
        self._sport_msg.fsm_mode = fsm_mode
        self._sport_msg.task_id = task_id
        self._sport_msg.task_time = task_time
        ok = self._sport.Write(self._sport_msg)
        self._bump("sportmodestate" if ok else "sportmodestate_write_errors")

    def _bump(self, key: str) -> None:
        counts = self._counts
        counts[key] = counts.get(key, 0) + 1

    def counts(self) -> dict[str, int]:
        return self._counts.copy()

    def readers(self) -> dict[str, int]:
        """How many readers each state topic's writer has matched now: who receives it (-1: unknown)."""
        writers = {"lowstate": self._lowstate, "lf_lowstate": self._lf_lowstate, "sportmodestate": self._sport,
                   "bmsstate": self._bms, "secondary_imu": self._imu.publisher,
                   "odommodestate": self._odom.publisher, "lf_odommodestate": self._lf_odom.publisher}
        return {name: _matched_readers(w) for name, w in writers.items()}


def _matched_readers(publisher: ChannelPublisher) -> int:
    """The publication-matched count the SDK's channel writer keeps (the SDK has no accessor)."""
    try:
        return int(channel_matched_readers(publisher_channel(publisher)))
    except AttributeError:
        return -1


class CommandSubscribers:
    """Readers of rt/lowcmd, rt/user_lowcmd and rt/arm_sdk, feeding a CommandIntake every frame in arrival order
    (frame_reader.py)."""

    def __init__(self, intake: CommandIntake, *, on_drop: Callable[[str, int, int], None] | None = None) -> None:
        """``on_drop(topic as the record names it, first arrival number dropped, how many)``."""
        self._readers: list[FrameReader] = []
        for topic, handler in ((topics.LOWCMD, intake.on_lowcmd), (topics.USER_LOWCMD, intake.on_user_lowcmd),
                               (topics.ARM_SDK, intake.on_arm_sdk)):
            name = topic.removeprefix("rt/")
            self._readers.append(FrameReader(topic, handler, on_drop=_dropped(name, intake, on_drop)))

    def stats(self) -> dict[str, dict[str, int]]:
        """Per topic: frames arrived, dropped, and the deepest backlog so far."""
        return {reader.topic.removeprefix("rt/"): reader.stats() for reader in self._readers}

    def stop(self) -> None:
        for reader in self._readers:
            reader.stop()


def _dropped(topic: str, intake: CommandIntake,
             on_drop: Callable[[str, int, int], None] | None) -> Callable[[int, int], None]:
    def dropped(first: int, count: int) -> None:
        intake.on_dropped(topic, count)
        if on_drop is not None:
            on_drop(topic, first, count)

    return dropped
