"""The struct decoders the body checks rely on agree with cyclonedds' own (de)serialisation."""

from __future__ import annotations

import random

from unitree_sdk2py.idl.default import unitree_hg_msg_dds__BmsState_, unitree_hg_msg_dds__LowState_

from g1_mode_manager.protocol.lowstate_fields import decode_body_fields, decode_body_fields_slowly
from g1_mode_manager.protocol.remote import RemoteState, decode_remote, encode_remote
from g1_mode_manager.sdk.battery_reader import decode_soc


def test_body_fields_by_struct_equal_the_full_deserialisation() -> None:
    rng = random.Random(7)
    for _ in range(20):
        msg = unitree_hg_msg_dds__LowState_()
        for motor in msg.motor_state:
            motor.q, motor.dq = rng.uniform(-3, 3), rng.uniform(-20, 20)
            motor.temperature = [rng.randrange(-40, 200), rng.randrange(-40, 200)]
        msg.imu_state.quaternion = [rng.uniform(-1, 1) for _ in range(4)]
        msg.imu_state.gyroscope = [rng.uniform(-9, 9) for _ in range(3)]
        msg.wireless_remote = list(encode_remote(RemoteState(frozenset({"L2", "B"}), lx=0.5)))
        data = msg.serialize()
        fast = decode_body_fields(data)
        assert fast == decode_body_fields_slowly(data)
        assert fast.casing_c[3] == msg.motor_state[3].temperature[0]
        assert fast.winding_c[3] == msg.motor_state[3].temperature[1]
        assert decode_remote(fast.remote).held("L2", "B")


def test_battery_soc_by_offset_equals_the_message() -> None:
    for soc in (0, 19, 77, 100):
        msg = unitree_hg_msg_dds__BmsState_()
        msg.soc, msg.current, msg.cell_vol = soc, -1234, [3700 + i for i in range(40)]
        assert decode_soc(msg.serialize()) == soc
