"""The message types: unitree_hg's own plus SportModeState_, which no Python build ships, and unitree_go's
SportModeState_ that the G1 publishes its odometry in (protocol.odom_fields)."""

from dataclasses import dataclass

import cyclonedds.idl as idl
import cyclonedds.idl.annotations as annotate
import cyclonedds.idl.types as types
from unitree_sdk2py.idl.unitree_api.msg.dds_ import Request_, Response_
from unitree_sdk2py.idl.unitree_go.msg.dds_ import SportModeState_ as OdomModeState_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import (  # re-exported: import message types from here
    BmsState_,
    IMUState_,
    LowCmd_,
    LowState_,
    MotorCmd_,
    MotorState_,
)

__all__ = [
    "BmsState_",
    "IMUState_",
    "LowCmd_",
    "LowState_",
    "MotorCmd_",
    "MotorState_",
    "OdomModeState_",
    "Request_",
    "Response_",
    "SportModeState_",
]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class SportModeState_(idl.IdlStruct, typename="unitree_hg.msg.dds_.SportModeState_"):
    """The G1's rt/sportmodestate (unitree_hg/msg/SportModeState.idl of the C++ SDK)."""

    fsm_id: types.uint32
    fsm_mode: types.uint32
    task_id: types.uint32
    task_time: types.float32
