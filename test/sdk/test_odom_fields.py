"""The struct layout of rt/odommodestate agrees with cyclonedds' own serialiser, both ways."""

from __future__ import annotations

import pytest
from cyclonedds.idl import Endianness
from unitree_sdk2py.idl.default import unitree_go_msg_dds__SportModeState_

from g1_mode_manager.protocol.idl import OdomModeState_
from g1_mode_manager.protocol.odom_fields import OdomFields, encode_odom
from g1_mode_manager.sdk.odom_reader import decode_odom


def _sample() -> OdomFields:
    return OdomFields(stamp_s=12.25, position=(1.5, -2.25, 0.75), velocity=(0.5, 0.125, 0.0), yaw_speed=0.375,
                      quaternion=(0.5, 0.5, 0.5, 0.5), gyroscope=(0.0, 0.25, -0.5), rpy=(0.125, -0.25, 1.5),
                      body_height=0.75)


def test_encoded_odom_deserialises_with_cyclonedds() -> None:
    m = OdomModeState_.deserialize(encode_odom(_sample()))
    assert (m.stamp.sec, m.stamp.nanosec) == (12, 250_000_000)
    assert list(m.position) == [1.5, -2.25, 0.75]
    assert list(m.velocity) == [0.5, 0.125, 0.0]
    assert m.yaw_speed == 0.375
    assert list(m.imu_state.quaternion) == [0.5, 0.5, 0.5, 0.5]
    assert list(m.imu_state.rpy) == [0.125, -0.25, 1.5]
    assert m.body_height == 0.75


def test_decoded_odom_matches_a_cyclonedds_serialisation() -> None:
    m = unitree_go_msg_dds__SportModeState_()
    m.stamp.sec, m.stamp.nanosec = 3, 500_000_000
    m.position, m.velocity, m.yaw_speed = [4.0, 5.0, 0.5], [0.25, -0.5, 0.0], -0.75
    m.imu_state.quaternion, m.imu_state.rpy, m.imu_state.gyroscope = [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [0, 0, 1]
    m.body_height, m.mode, m.gait_type, m.foot_raise_height = 0.7, 2, 1, 0.08  # fields around the ones read
    m.path_point[9].vyaw = 9.0
    f = decode_odom(m.serialize())
    assert f.stamp_s == pytest.approx(3.5)
    assert f.position == (4.0, 5.0, 0.5) and f.velocity == (0.25, -0.5, 0.0) and f.yaw_speed == -0.75
    assert f.quaternion == (1.0, 0.0, 0.0, 0.0) and f.rpy == (0.0, 0.0, 0.5) and f.gyroscope == (0.0, 0.0, 1.0)
    assert f.body_height == pytest.approx(0.7)


def test_big_endian_odom_takes_the_slow_path() -> None:
    m = unitree_go_msg_dds__SportModeState_()
    m.position = [1.0, 2.0, 3.0]
    data = m.serialize(endianness=Endianness.Big)
    assert decode_odom(data).position == (1.0, 2.0, 3.0)
