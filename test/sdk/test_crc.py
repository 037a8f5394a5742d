"""The fast CRC equals the SDK's on random unitree_hg frames, and costs a fraction of it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_, unitree_hg_msg_dds__LowState_
from unitree_sdk2py.utils.crc import CRC

from g1_mode_manager.protocol import crc
from g1_mode_manager.protocol.idl import LowCmd_, LowState_, MotorCmd_

u8 = st.integers(0, 0xFF)
i16 = st.integers(-0x8000, 0x7FFF)
u32 = st.integers(0, 0xFFFFFFFF)
f32 = st.floats(width=32, allow_nan=False)


@st.composite
def lowcmds(draw: st.DrawFn) -> LowCmd_:
    motors = [
        MotorCmd_(mode=draw(u8), q=draw(f32), dq=draw(f32), tau=draw(f32), kp=draw(f32), kd=draw(f32),
                  reserve=draw(u32))
        for _ in range(35)
    ]
    return LowCmd_(mode_pr=draw(u8), mode_machine=draw(u8), motor_cmd=motors,
                   reserve=draw(st.lists(u32, min_size=4, max_size=4)), crc=draw(u32))


@st.composite
def lowstates(draw: st.DrawFn) -> LowState_:
    msg = unitree_hg_msg_dds__LowState_()
    msg.version = draw(st.lists(u32, min_size=2, max_size=2))
    msg.mode_pr, msg.mode_machine, msg.tick = draw(u8), draw(u8), draw(u32)
    imu = msg.imu_state
    imu.quaternion = draw(st.lists(f32, min_size=4, max_size=4))
    imu.gyroscope = draw(st.lists(f32, min_size=3, max_size=3))
    imu.accelerometer = draw(st.lists(f32, min_size=3, max_size=3))
    imu.rpy = draw(st.lists(f32, min_size=3, max_size=3))
    imu.temperature = draw(i16)
    for m in msg.motor_state:
        m.mode, m.q, m.dq, m.ddq, m.tau_est, m.vol = draw(u8), draw(f32), draw(f32), draw(f32), draw(f32), draw(f32)
        m.temperature = [draw(i16), draw(i16)]
        m.sensor = [draw(u32), draw(u32)]
        m.motorstate = draw(u32)
        m.reserve = draw(st.lists(u32, min_size=4, max_size=4))
    msg.wireless_remote = draw(st.lists(u8, min_size=40, max_size=40))
    msg.reserve = draw(st.lists(u32, min_size=4, max_size=4))
    msg.crc = draw(u32)
    return msg


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lowcmds())
def test_lowcmd_crc_equals_sdk(msg: LowCmd_) -> None:
    assert crc.lowcmd_crc(msg) == CRC().Crc(msg)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lowstates())
def test_lowstate_crc_equals_sdk(msg: LowState_) -> None:
    assert crc.lowstate_crc(msg) == CRC().Crc(msg)


@settings(max_examples=20, deadline=None)
@given(st.binary(min_size=4, max_size=64).map(lambda b: b[: len(b) - len(b) % 4]))
def test_python_fallback_equals_c(data: bytes) -> None:
    assert crc.crc32_words_py(data) == crc.crc32_words(data)


def test_crc_ignores_its_own_field() -> None:
    msg = unitree_hg_msg_dds__LowCmd_()
    before = crc.lowcmd_crc(msg)
    msg.crc = 12345
    assert crc.lowcmd_crc(msg) == before


@pytest.mark.parametrize("words", [1, 2, 250, 522])
def test_the_crc_of_an_array_in_place_equals_the_byte_table_definition(words: int) -> None:
    data = np.random.default_rng(words).integers(0, 256, 4 * words, dtype=np.uint8)
    assert crc.crc32_of_array(data, words) == crc.crc32_words_py(data.tobytes()) == crc.crc32_words(data.tobytes())
