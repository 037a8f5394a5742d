"""Wire formats: LowCmdFrame bytes equal cyclonedds' serialisation with the SDK's CRC; lowstate decoding."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowState_
from unitree_sdk2py.utils.crc import CRC

from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.dds import apply_robot_type_compat
from g1_mode_manager.protocol.idl import LowCmd_, LowState_
from g1_mode_manager.sdk.arm_sdk import build_arm_sdk_frame
from g1_mode_manager.sdk.frames import LowCmdFrame
from g1_mode_manager.sdk.lowcmd import build_lowcmd_frame
from g1_mode_manager.sdk.state_readers import decode_lowstate

f32 = st.floats(-1e4, 1e4, width=32)
commands = st.builds(MotorCommand, q=f32, dq=f32, tau=f32, kp=st.floats(0, 500, width=32), kd=st.floats(0, 50, width=32))


def serialized(msg: LowCmd_ | LowState_) -> bytes:
    apply_robot_type_compat()
    return msg.serialize()


@settings(max_examples=40, deadline=None)
@given(st.lists(commands, min_size=29, max_size=29), st.integers(0, 255))
def test_lowcmd_frame_bytes_and_crc_equal_the_sdk(cmds: list[MotorCommand], mode_machine: int) -> None:
    frame = build_lowcmd_frame(LowCmdFrame(), cmds, mode_machine)
    msg = frame.to_message()
    expected = serialized(msg)
    assert frame.cdr(expected[:4]) == expected
    assert msg.crc == CRC().Crc(msg)
    assert [m.mode for m in msg.motor_cmd] == [1] * 29 + [0] * 6
    assert (msg.mode_pr, msg.mode_machine) == (0, mode_machine)


@settings(max_examples=40, deadline=None)
@given(st.lists(commands, min_size=17, max_size=17), st.floats(-5, 5))
def test_arm_sdk_frame_bytes_crc_and_weight(cmds: list[MotorCommand], weight: float) -> None:
    frame = build_arm_sdk_frame(LowCmdFrame(), cmds, weight)
    msg = frame.to_message()
    expected = serialized(msg)
    assert frame.cdr(expected[:4]) == expected
    assert msg.crc == CRC().Crc(msg)
    assert [m.mode for m in msg.motor_cmd] == [0] * 12 + [1] * 17 + [0] * 6
    assert msg.motor_cmd[29].q == float(np.float32(min(1.0, max(0.0, weight))))  # float32 on the wire


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 255), st.integers(0, 0xFFFFFFFF), st.lists(f32, min_size=35, max_size=35),
       st.lists(f32, min_size=35, max_size=35), st.integers(-0x8000, 0x7FFF))
def test_lowstate_decoding_equals_full_deserialisation(mode_machine: int, tick: int, q: list[float],
                                                      dq: list[float], temperature: int) -> None:
    msg = unitree_hg_msg_dds__LowState_()
    msg.mode_machine, msg.tick, msg.imu_state.temperature = mode_machine, tick, temperature
    for motor, qi, dqi in zip(msg.motor_state, q, dq, strict=True):
        motor.q, motor.dq, motor.mode, motor.temperature = qi, dqi, 1, [temperature, 3]
    snapshot = decode_lowstate(serialized(msg))
    assert (snapshot.mode_machine, snapshot.tick) == (mode_machine, tick)
    assert snapshot.q == tuple(q[:29])
    assert snapshot.message().motor_state[5].dq == dq[5]
