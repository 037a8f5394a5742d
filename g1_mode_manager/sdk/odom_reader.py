"""rt/lf/odommodestate, the robot's state estimate at about 20 Hz, read when asked (odometry, walk judging)."""

from __future__ import annotations

import time

from g1_mode_manager.core.port import OdomSample
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.odom_fields import OdomFields, OdomModeState_, decode_odom
from g1_mode_manager.sdk.state_readers import LatestSample


class OdomReader(LatestSample[OdomFields]):
    def __init__(self) -> None:
        super().__init__(topics.LF_ODOMMODESTATE, OdomModeState_, decode_odom)

    def sample(self) -> OdomSample | None:
        fields, stamp, count = self.latest()
        return None if fields is None else OdomSample(fields, time.monotonic() - stamp, count)
