"""rt/arm_sdk frames: waist and arm targets blended into the built-in controller by a weight 0..1."""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence

from unitree_sdk2py.core.channel import ChannelPublisher

from g1_mode_manager.core.port import MotorCommand, RobotError
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.api_ids import ERR_CLIENT_SEND
from g1_mode_manager.protocol.crc import lowcmd_crc
from g1_mode_manager.protocol.idl import LowCmd_
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS, ARM_SDK_WEIGHT_INDEX, MOTOR_ENABLED
from g1_mode_manager.sdk.frames import check_commands, fill_motor, new_lowcmd


def build_arm_sdk_frame(msg: LowCmd_, targets: Sequence[MotorCommand], weight: float) -> LowCmd_:
    """Fill ``msg``: motors 12..28 enabled with ``targets``, motor_cmd[29].q = weight clamped to 0..1, CRC.

    Raises ValueError for a wrong count or a non-finite value (the weight included).
    """
    check_commands("arm_sdk", targets, len(ARM_SDK_JOINTS))
    if isinstance(weight, bool) or not isinstance(weight, int | float) or not math.isfinite(weight):
        raise ValueError(f"arm_sdk: weight must be a finite number, got {weight!r}")
    motors = msg.motor_cmd
    for index, command in zip(ARM_SDK_JOINTS, targets, strict=True):
        fill_motor(motors[index], command, MOTOR_ENABLED)
    motors[ARM_SDK_WEIGHT_INDEX].q = min(1.0, max(0.0, float(weight)))
    msg.crc = lowcmd_crc(msg)
    return msg


class ArmSdkWriter:
    """Publishes rt/arm_sdk frames (creating it costs the SDK writer's 0.2 s sleep). Thread-safe."""

    def __init__(self, topic: str = topics.ARM_SDK) -> None:
        self.topic = topic
        self._lock = threading.Lock()
        self._msg = new_lowcmd()
        self._publisher = ChannelPublisher(topic, LowCmd_)
        self._publisher.Init()

    def write(self, targets: Sequence[MotorCommand], weight: float) -> None:
        with self._lock:
            msg = build_arm_sdk_frame(self._msg, targets, weight)
            if not self._publisher.Write(msg):
                raise RobotError("arm_sdk", ERR_CLIENT_SEND, f"DDS write on {self.topic} failed")

    def close(self) -> None:
        self._publisher.Close()
