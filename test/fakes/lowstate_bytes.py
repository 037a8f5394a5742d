"""A serialised LowState_ with a chosen attitude, remote keys and motor temperatures (for the body checks)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowState_

from g1_mode_manager.protocol.remote import RemoteState, encode_remote


def lowstate_bytes(*, tilt: float = 0.0, keys: tuple[str, ...] = (), winding: int = 40,
                   q: Sequence[float] = ()) -> bytes:
    """Pitched by ``tilt`` rad, these keys held, every winding at ``winding`` °C (casings 35 °C), the joints at
    ``q`` (motor order; 0 where not given)."""
    msg = unitree_hg_msg_dds__LowState_()
    msg.imu_state.quaternion = [math.cos(tilt / 2), 0.0, math.sin(tilt / 2), 0.0]
    for motor in msg.motor_state:
        motor.temperature = [35, winding]
    for motor, position in zip(msg.motor_state, q, strict=False):
        motor.q = float(position)
    msg.wireless_remote = list(encode_remote(RemoteState(frozenset(keys))))
    return msg.serialize()
