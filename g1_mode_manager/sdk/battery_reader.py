"""rt/lf/bmsstate, the robot's battery: its state of charge, read when asked (a few samples a second)."""

from __future__ import annotations

import time
from typing import Final

from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.idl import BmsState_
from g1_mode_manager.sdk.state_readers import LatestSample

#: ``soc`` (uint8, %) after the encapsulation header: version_high, version_low, fn, cell_vol[40] (uint16),
#: bmsvoltage[3] (uint32), current (int32) come first (checked against cyclonedds by a test).
_SOC_AT: Final = 4 + 100
_LITTLE_ENDIAN_ENCODINGS: Final = (0x01, 0x07)


def decode_soc(data: bytes) -> float:
    if data[0] == 0 and data[1] in _LITTLE_ENDIAN_ENCODINGS and len(data) > _SOC_AT:
        return float(data[_SOC_AT])
    return float(BmsState_.deserialize(data).soc)


class BatteryReader(LatestSample[float]):
    def __init__(self) -> None:
        super().__init__(topics.LF_BMSSTATE, BmsState_, decode_soc)

    def soc(self) -> tuple[float, float] | None:
        """(state of charge in %, age of the sample in s), or None before the first sample."""
        sample, stamp, _ = self.latest()
        return None if sample is None else (sample, time.monotonic() - stamp)
