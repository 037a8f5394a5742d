"""What the node's per-message codecs cost: rt/lowstate decoding and the frames' CRC, beside the full paths.

``python -m bench.decode_cost [N]`` prints, in microseconds per message: the node's rt/lowstate snapshot
decode and its joint-state + IMU field decode against cyclonedds' full deserialisation, and the LowCmd_ and
LowState_ CRC against the Unitree SDK's ``CRC().Crc``. Pure CPU, no DDS; the figures vary with the machine.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_, unitree_hg_msg_dds__LowState_
from unitree_sdk2py.utils.crc import CRC

from g1_mode_manager.protocol import crc
from g1_mode_manager.protocol.dds import apply_robot_type_compat
from g1_mode_manager.protocol.idl import LowState_
from g1_mode_manager.protocol.lowstate_fields import decode_fields
from g1_mode_manager.sdk.state_readers import decode_lowstate


def per_call_us(fn: Callable[[Any], object], arg: Any, n: int) -> float:
    for _ in range(min(n, 100)):  # warm up
        fn(arg)
    start = time.perf_counter()
    for _ in range(n):
        fn(arg)
    return (time.perf_counter() - start) / n * 1e6


def main(argv: list[str]) -> int:
    n = int(argv[0]) if argv else 2000
    apply_robot_type_compat()
    state, cmd = unitree_hg_msg_dds__LowState_(), unitree_hg_msg_dds__LowCmd_()
    data = state.serialize()
    sdk = CRC()
    assert crc.lowcmd_crc(cmd) == sdk.Crc(cmd) and crc.lowstate_crc(state) == sdk.Crc(state)
    rows = {
        "rt/lowstate snapshot decode": per_call_us(decode_lowstate, data, n),
        "rt/lowstate joint state + IMU decode": per_call_us(decode_fields, data, n),
        "rt/lowstate full deserialisation (cyclonedds)": per_call_us(LowState_.deserialize, data, max(1, n // 20)),
        "LowCmd_ CRC (the node's)": per_call_us(crc.lowcmd_crc, cmd, n),
        "LowCmd_ CRC (SDK CRC().Crc)": per_call_us(sdk.Crc, cmd, max(1, n // 4)),
        "LowState_ CRC (the node's)": per_call_us(crc.lowstate_crc, state, n),
        "LowState_ CRC (SDK CRC().Crc)": per_call_us(sdk.Crc, state, max(1, n // 10)),
    }
    for name, us in rows.items():
        print(f"{name}: {us:.1f} us")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
