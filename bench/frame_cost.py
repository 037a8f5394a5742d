"""What one frame costs the node's robot port: build, CRC and write of an rt/arm_sdk and an rt/lowcmd frame.

``python -m bench.frame_cost [DOMAIN] [N]`` writes N frames of each (no reader: the write serialises and
hands the sample to Cyclone all the same) on an SDK domain of its own on loopback and prints the mean time
per frame in microseconds. Nothing else runs; the figure is the port's share of a relayed stream.
"""

from __future__ import annotations

import sys
import time

from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.dds import init_channels
from g1_mode_manager.protocol.motors import NUM_JOINTS


def main(argv: list[str]) -> int:
    domain = int(argv[0]) if argv else 97
    n = int(argv[1]) if len(argv) > 1 else 2000
    init_channels(domain, "lo")
    from g1_mode_manager.sdk.arm_sdk import ArmSdkWriter
    from g1_mode_manager.sdk.lowcmd import LowCmdWriter

    arm, low = ArmSdkWriter(), LowCmdWriter(lambda: 1)
    try:
        arm_targets = [MotorCommand(q=0.1, kp=50.0, kd=1.0)] * 17
        joints = [MotorCommand(q=0.1, kp=50.0, kd=1.0)] * NUM_JOINTS
        for name, write in (("arm_sdk", lambda: arm.write(arm_targets, 0.5)), ("lowcmd", lambda: low.write(joints))):
            for _ in range(100):  # warm up
                write()
            start = time.perf_counter()
            for _ in range(n):
                write()
            print(f"{name} frame build + CRC + write: {(time.perf_counter() - start) / n * 1e6:.0f} us (n={n})")
    finally:
        arm.close()
        low.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
