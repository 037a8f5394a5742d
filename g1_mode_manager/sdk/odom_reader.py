"""rt/lf/odommodestate, the robot's state estimate at about 20 Hz, read when asked (odometry, walk judging)."""

from __future__ import annotations

import time

from g1_mode_manager.core.port import OdomSample
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.idl import OdomModeState_
from g1_mode_manager.protocol.odom_fields import OdomFields, unpack_odom
from g1_mode_manager.sdk.state_readers import LatestSample


def decode_odom(data: bytes) -> OdomFields:
    """By the struct layout (protocol.odom_fields), or by full deserialisation for other encodings."""
    fields = unpack_odom(data)
    if fields is not None:
        return fields
    m = OdomModeState_.deserialize(data)
    imu = m.imu_state
    return OdomFields(stamp_s=m.stamp.sec + m.stamp.nanosec * 1e-9, position=tuple(m.position),
                      velocity=tuple(m.velocity), yaw_speed=m.yaw_speed, quaternion=tuple(imu.quaternion),
                      gyroscope=tuple(imu.gyroscope), rpy=tuple(imu.rpy), body_height=m.body_height)  # type: ignore[arg-type]


class OdomReader(LatestSample[OdomFields]):
    def __init__(self) -> None:
        super().__init__(topics.LF_ODOMMODESTATE, OdomModeState_, decode_odom)

    def sample(self) -> OdomSample | None:
        fields, stamp, count = self.latest()
        return None if fields is None else OdomSample(fields, time.monotonic() - stamp, count)
