"""Joint states and IMU decoded from raw rt/lowstate bytes equal the full deserialisation, and are cheap."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowState_

from g1_mode_manager.protocol.dds import apply_robot_type_compat
from g1_mode_manager.protocol.idl import LowState_
from g1_mode_manager.protocol.lowstate_fields import decode_fields, decode_fields_slowly

f32 = st.floats(-1e4, 1e4, width=32)
motors = st.lists(f32, min_size=35, max_size=35)


def serialized(msg: LowState_) -> bytes:
    apply_robot_type_compat()
    return msg.serialize()


@settings(max_examples=40, deadline=None)
@given(motors, motors, motors, motors, st.lists(f32, min_size=10, max_size=10), st.integers(-0x8000, 0x7FFF))
def test_fields_equal_full_deserialisation(q, dq, ddq, tau, imu, temperature) -> None:
    msg = unitree_hg_msg_dds__LowState_()
    msg.imu_state.quaternion, msg.imu_state.gyroscope, msg.imu_state.accelerometer = imu[:4], imu[4:7], imu[7:]
    msg.imu_state.rpy, msg.imu_state.temperature = [9.0, 9.0, 9.0], temperature
    for m, values in zip(msg.motor_state, zip(q, dq, ddq, tau, strict=True), strict=True):
        m.q, m.dq, m.ddq, m.tau_est = values
        m.mode, m.temperature, m.vol = 1, [temperature, 7], 48.0
    data = serialized(msg)
    fields = decode_fields(data)
    assert fields.q == tuple(q[:29]) and fields.dq == tuple(dq[:29]) and fields.tau == tuple(tau[:29])
    assert fields.quaternion == tuple(imu[:4])
    assert fields.gyroscope == tuple(imu[4:7]) and fields.accelerometer == tuple(imu[7:])
    assert decode_fields_slowly(data) == fields
