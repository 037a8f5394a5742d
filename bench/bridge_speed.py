"""Speed of the sim bridge: rt/lowstate packing (ours vs the SDK's path) and the bridge's real-time
factor at full speed (policy + 500 Hz rt/lowstate + 50 Hz sportmodestate and ROS topics), with and
without a rt/lowstate reader in another process.

    flock /tmp/g1_sim_cpu.lock .venv/bin/python -m bench.bridge_speed [--seconds 5] [--domain 231]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time

import numpy as np

_READER = """
import sys, time
from g1_mode_manager.protocol.dds import init_channels
init_channels(int(sys.argv[1]), "lo")
from unitree_sdk2py.core.channel import ChannelSubscriber
from g1_mode_manager.protocol.idl import LowState_
sub = ChannelSubscriber("rt/lowstate", LowState_)
sub.Init(lambda m: None, 1)
try:
    while True:
        time.sleep(1.0)
except KeyboardInterrupt:
    pass
"""


def packing(n: int = 3000) -> None:
    from unitree_sdk2py.utils.crc import CRC

    from g1_mode_manager.protocol.dds import apply_robot_type_compat

    apply_robot_type_compat()
    from g1_sim.bridge.lowstate_codec import LowStatePacker, default_lowstate

    packer = LowStatePacker()
    z = np.zeros(29)
    t0 = time.perf_counter()
    for i in range(n):
        packer.pack(z, z, z, np.array([1.0, 0, 0, 0]), z[:3], z[:3], z[:3], i).serialize(use_version_2=False)
    ours = (time.perf_counter() - t0) / n
    msg, crc = default_lowstate(5), CRC()
    t0 = time.perf_counter()
    for _ in range(n // 10):
        msg.crc = crc.Crc(msg)
        msg.serialize(use_version_2=False)
    sdk = (time.perf_counter() - t0) / (n // 10)
    print(f"rt/lowstate frame: packed here {ours * 1e6:.0f} us, SDK CRC + cyclonedds serialise {sdk * 1e6:.0f} us")


def bridge_rtf(domain: int, seconds: float, with_reader: bool) -> float:
    from g1_mode_manager.protocol.dds import init_channels
    from harness.sim_bridge import shared_sim_status, start_sim_bridge

    init_channels(domain, "lo")
    bridge = start_sim_bridge(domain, speed=0.0)
    reader = None
    try:
        if with_reader:
            reader = subprocess.Popen([sys.executable, "-c", _READER, str(domain)], start_new_session=True)
            time.sleep(3.0)
        status = shared_sim_status()  # one for the process: SDK entities must outlive every bridge
        s0, t0 = status.wait_ready(), time.monotonic()
        time.sleep(seconds)
        s1, t1 = status.get(), time.monotonic()
        return (s1["sim_time"] - s0["sim_time"]) / (t1 - t0)
    finally:
        if reader is not None and reader.poll() is None:
            os.killpg(reader.pid, signal.SIGINT)
            reader.wait(10)
        bridge.stop()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="wall seconds per measurement")
    parser.add_argument("--domain", type=int, default=231, help="SDK DDS domain (loopback) for the run")
    args = parser.parse_args(argv)
    from harness.processes import restore_sigint

    restore_sigint()  # the reader is stopped with SIGINT, however this was started
    packing()
    # One SDK domain per process: the second measurement reuses it with a fresh bridge.
    for with_reader in (False, True):
        rtf = bridge_rtf(args.domain, args.seconds, with_reader)
        print(f"bridge at full speed, {'with' if with_reader else 'without'} a rt/lowstate reader process: "
              f"{rtf:.1f}x real time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
