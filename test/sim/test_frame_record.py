"""The sim's record holds every frame that reached it, in arrival order, each with its own receive stamp.

The record is the judge of the project's safety tests, so it is checked here against an independent reader of the
same topic: a plain Cyclone reader in this process with a history deep enough to keep every frame (the SDK's own
``ChannelSubscriber`` keeps one sample and would itself drop frames on a loaded machine).
"""

from __future__ import annotations

import functools
import math
import os
import signal
import threading
import time
from typing import Any

import pytest
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from unitree_sdk2py.core.channel import ChannelPublisher
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_

from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.crc import lowcmd_crc
from g1_mode_manager.protocol.cyclone_internals import take_serialized
from g1_mode_manager.protocol.dds import sdk_participant
from g1_mode_manager.protocol.idl import LowCmd_
from g1_mode_manager.protocol.unitree_sdk_internals import channel_matched_readers, publisher_channel
from g1_sim.bridge.frame_reader import FrameReader
from support.mode_manager import wait_until
from support.sim_bridge import shared_sim_status, sim_bridge_factory  # noqa: F401  (fixture)
from support.sim_record import IncompleteRecordError, SimRecord

pytestmark = pytest.mark.sim

#: SDK entities of this file's tests, never freed while the process lives.
_KEPT: list[Any] = []
RATE_HZ = 500.0
STREAM_S = 10.0
#: The sim is frozen (SIGSTOP) this long mid-stream: a loaded machine's starved sim, made certain.
FROZEN_S = 0.3


def _frame(kp: float) -> LowCmd_:
    """A frame told apart by its stiffness alone (the record keeps ``kp_max``), its CRC right."""
    msg = unitree_hg_msg_dds__LowCmd_()
    msg.mode_machine = 5
    msg.motor_cmd[0].mode, msg.motor_cmd[0].kp = 1, kp
    msg.crc = lowcmd_crc(msg)
    return msg


@functools.cache
def _user_lowcmd_publisher() -> ChannelPublisher:
    """One for the process: an SDK writer garbage-collected while later readers of its topic come and go has its
    matched-status listener called after it was freed (harness/sim_bridge.py: pitfall)."""
    pub = ChannelPublisher(topics.USER_LOWCMD, LowCmd_)
    pub.Init()
    return pub


class DeepReader:
    """Every sample of a topic, taken without a listener into a history that holds them all."""

    def __init__(self, topic: str, depth: int) -> None:
        participant = sdk_participant()
        self._reader = DataReader(participant, Topic(participant, topic, LowCmd_), Qos(Policy.History.KeepLast(depth)))
        self.kps: list[float] = []

    def drain(self) -> None:
        while taken := take_serialized(self._reader, 256):
            self.kps += [float(LowCmd_.deserialize(raw).motor_cmd[0].kp) for raw, info in taken if info.valid_data]


def test_a_500_hz_stream_is_on_the_record_frame_for_frame_as_an_independent_reader_got_it(
        sdk_channels: int, sim_bridge_factory, tmp_path) -> None:  # noqa: F811
    record_path = tmp_path / "record.jsonl"
    proc = sim_bridge_factory(extra_args=("--record", str(record_path)))
    shared_sim_status().wait_ready()
    record = SimRecord(record_path)
    frames = int(RATE_HZ * STREAM_S)
    independent = DeepReader(topics.USER_LOWCMD, depth=2 * frames)
    pub = _user_lowcmd_publisher()

    def recorded(since: float) -> list[dict[str, Any]]:
        return [e for e in record.events(since) if e["k"] == "frame" and e["topic"] == "user_lowcmd"]

    # both readers matched: a probe frame (kp 0) is on the record
    assert wait_until(lambda: channel_matched_readers(publisher_channel(pub)) >= 2, 10.0)
    assert wait_until(lambda: pub.Write(_frame(0.0), 1.0) and time.sleep(0.05) is None and recorded(-math.inf), 10.0)
    time.sleep(0.1)
    independent.drain()
    independent.kps.clear()
    t0 = time.monotonic()
    sent_at: dict[float, float] = {}
    period = 1.0 / RATE_HZ
    for k in range(1, frames + 1):
        if k == frames // 2:
            os.kill(proc.proc.pid, signal.SIGSTOP)
            threading.Timer(FROZEN_S, os.kill, (proc.proc.pid, signal.SIGCONT)).start()
        kp = float(k)  # exact in float32 up to 2**24
        sent_at[kp] = time.monotonic()
        assert pub.Write(_frame(kp), 1.0)
        if k % 100 == 0:
            independent.drain()
        time.sleep(max(0.0, t0 + k * period - time.monotonic()))
    time.sleep(FROZEN_S)  # the timer has thawed it
    os.kill(proc.proc.pid, signal.SIGCONT)

    assert wait_until(lambda: len(recorded(t0)) >= frames, 10.0), f"{len(recorded(t0))} of {frames} on the record"
    independent.drain()
    on_record = recorded(t0)
    assert independent.kps == [float(k) for k in range(1, frames + 1)], "the independent reader missed frames"
    assert [e["kp_max"] for e in on_record] == independent.kps
    numbers = [e["n"] for e in on_record]
    assert numbers == list(range(numbers[0], numbers[0] + frames))
    early = [(e["kp_max"], e["t"] - sent_at[e["kp_max"]]) for e in on_record if e["t"] < sent_at[e["kp_max"]]]
    assert not early, f"frames stamped before they were sent: {early[:5]}"
    # each frame's writer stamp (its DDS source timestamp) is the write, read on this machine's one clock: between the
    # Write call's start and the sim's delivery, and the sim applied it after delivering it (1 ms: the clocks' reads)
    off = [(e["kp_max"], e["src"] - sent_at[e["kp_max"]], e["t"] - e["src"]) for e in on_record
           if not sent_at[e["kp_max"]] - 1e-3 <= e["src"] <= e["t"] + 1e-3 or e["ap"] < e["t"]]
    assert not off, f"frames whose write or application stamp is not between their write and their use: {off[:5]}"


def test_a_reader_that_falls_too_far_behind_says_what_it_dropped_and_goes_on_in_order(sdk_channels: int) -> None:
    topic = f"test/frame_reader_{os.getpid()}"
    entered, release = threading.Event(), threading.Event()
    got: list[tuple[float, float, int]] = []
    drops: list[tuple[int, int]] = []

    def handle(msg: LowCmd_, t: float, n: int, written: float) -> None:
        assert written <= t + 1e-3, "written after it was delivered"
        entered.set()
        release.wait(10.0)
        got.append((float(msg.motor_cmd[0].kp), t, n))

    reader = FrameReader(topic, handle, on_drop=lambda first, count: drops.append((first, count)), max_backlog=5)
    pub = ChannelPublisher(topic, LowCmd_)  # kept for the process (harness/sim_bridge.py: pitfall)
    _KEPT.append(pub)
    pub.Init()
    try:
        assert wait_until(lambda: channel_matched_readers(publisher_channel(pub)) >= 1, 10.0)
        sent = [time.monotonic()]
        assert pub.Write(_frame(1.0), 1.0)
        assert entered.wait(5.0)
        for kp in (1.0, 1.0, 2.0, 2.0, 2.0, 3.0, 3.0, 3.0, 3.0, 4.0):  # identical frames: a held pose
            sent.append(time.monotonic())
            assert pub.Write(_frame(kp), 1.0)
            time.sleep(0.005)
        # the handler is stuck in the first frame: 5 wait behind it, the rest are dropped
        assert wait_until(lambda: reader.stats()["arrived"] == len(sent), 5.0)
        release.set()
        assert wait_until(lambda: len(got) == 6 and len(drops) == 1, 5.0)
        assert reader.stats() == {"arrived": 11, "dropped": 5, "deepest": 5}
        assert drops == [(7, 5)]
        assert [n for _, _, n in got] == [1, 2, 3, 4, 5, 6]
        assert [kp for kp, _, _ in got] == [1.0, 1.0, 1.0, 2.0, 2.0, 2.0]
        assert all(sent[n - 1] <= t for _, t, n in got), "a frame stamped before it was sent"
        pub.Write(_frame(5.0), 1.0)
        assert wait_until(lambda: len(got) == 7, 5.0) and got[-1][0] == 5.0 and got[-1][2] == 12
    finally:
        release.set()
        reader.stop()


def test_a_record_with_a_drop_cannot_be_read(tmp_path) -> None:
    path = tmp_path / "record.jsonl"
    path.write_text('{"k":"frame","t":1.0,"topic":"user_lowcmd","n":1}\n'
                    '{"k":"drop","t":1.1,"topic":"user_lowcmd","n":2,"count":3}\n')
    record = SimRecord(path)
    with pytest.raises(IncompleteRecordError, match="dropped"):
        record.events()
    with pytest.raises(IncompleteRecordError):
        record.events()  # and stays unreadable


def test_a_record_read_from_now_starts_at_the_next_whole_line(tmp_path) -> None:
    """A reader that starts while the bridge's write of a line is half seen skips the rest of that line."""
    path = tmp_path / "record.jsonl"
    path.write_text('{"k":"body","t":1.0,"z":0.7}\n{"k":"body","t":1.01,')  # the second line half written
    record = SimRecord(path, from_now=True)
    with path.open("a") as f:
        f.write('"z":0.7}\n{"k":"req","t":1.02,"api":7101}\n')
    assert [(e["k"], e["t"]) for e in record.events()] == [("req", 1.02)]
    at_a_boundary = SimRecord(path, from_now=True)
    with path.open("a") as f:
        f.write('{"k":"body","t":1.03,"z":0.7}\n')
    assert [e["t"] for e in at_a_boundary.events()] == [1.03]
