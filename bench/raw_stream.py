"""The raw reference of `make bench`: Unitree's own SDK publisher writing a LowCmd_ stream from a process of its
own, as a user's controller would (``ChannelPublisher``, the message filled field by field, the SDK's
``CRC().Crc``, ``Write``), with nothing else in the process.

Run by bench/run.py: ``python -m bench.raw_stream --domain D --topic rt/lowcmd --rate 500 --seconds 8 --out F``.
mode_machine is read once from rt/lowstate before the stream starts (the subscriber is closed again, so the
process's CPU is the publisher's alone). Each frame carries a marker in motor 0's kp (``marker(seq)``), which
the sim's record shows as the frame's ``kp_max``: the bench matches what the robot received with when it was
sent. Writes JSON: the process's CPU (all its threads, over the stream only) and (marker, send time) pairs.
"""

from __future__ import annotations

import argparse
import json
import threading
import time

from g1_mode_manager.protocol.dds import init_channels
from harness.rate import run_at_rate

#: Marker values are exact in float32 (multiples of 1/256) and unique over 4096 frames.
MARKERS = 4096


def marker(seq: int) -> float:
    return 1.0 + (seq % MARKERS) / 256.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="raw_stream", description=__doc__.split("\n\n")[0])
    parser.add_argument("--domain", type=int, required=True)
    parser.add_argument("--topic", choices=("rt/lowcmd", "rt/arm_sdk"), required=True)
    parser.add_argument("--rate", type=float, required=True)
    parser.add_argument("--seconds", type=float, required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)

    init_channels(args.domain, "lo")  # the same loopback Cyclone set-up as the node's; the rest is the SDK's
    from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowCmd_, LowState_
    from unitree_sdk2py.utils.crc import CRC

    state = ChannelSubscriber("rt/lowstate", LowState_)
    state.Init()
    first = state.Read(5.0)
    if first is None:
        raise SystemExit("no rt/lowstate within 5 s")
    mode_machine = int(first.mode_machine)
    state.Close()

    arm = args.topic == "rt/arm_sdk"
    joints = range(12, 29) if arm else range(29)
    pub = ChannelPublisher(args.topic, LowCmd_)
    pub.Init()
    time.sleep(0.5)  # discovery: the first frames would reach nobody
    msg = unitree_hg_msg_dds__LowCmd_()
    crc = CRC()
    sends: list[tuple[float, float]] = []
    start_cpu, start = time.process_time(), time.monotonic()
    seq = 0

    def write() -> bool:
        nonlocal seq
        if time.monotonic() - start >= args.seconds:
            return False
        msg.mode_pr = 0
        msg.mode_machine = mode_machine
        for i in joints:
            m = msg.motor_cmd[i]
            m.mode = 1
            m.q = 0.0
            m.dq = 0.0
            m.tau = 0.0
            m.kp = marker(seq) if i == joints[0] else (40.0 if arm else 0.0)
            m.kd = 2.0
        if arm:
            msg.motor_cmd[29].q = 0.0  # weight 0: the built-in controller keeps the arms
        msg.crc = crc.Crc(msg)
        sent = time.monotonic()
        pub.Write(msg)
        sends.append((marker(seq), sent))
        seq += 1
        return True

    run_at_rate(args.rate, write, threading.Event())
    cpu_pct = 100.0 * (time.process_time() - start_cpu) / (time.monotonic() - start)
    with open(args.out, "w") as f:
        json.dump({"cpu_pct": cpu_pct, "rate_hz": seq / (time.monotonic() - start), "sends": sends}, f)
    pub.Close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
