"""rt/arm_sdk frames: waist and arm targets blended into the built-in controller by a weight 0..1."""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from operator import attrgetter

from g1_mode_manager.core.port import MotorCommand, RobotError
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.api_ids import ERR_CLIENT_SEND
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS, ARM_SDK_WEIGHT_INDEX, MOTOR_ENABLED
from g1_mode_manager.sdk.frames import FrameWriter, LowCmdFrame, check_columns

_FIELDS = attrgetter("q", "dq", "tau", "kp", "kd")


def build_arm_sdk_frame(frame: LowCmdFrame, targets: Sequence[MotorCommand], weight: float) -> LowCmdFrame:
    """Fill ``frame``: motors 12..28 enabled with ``targets``, motor_cmd[29].q = weight clamped to 0..1.

    Raises ValueError for a wrong count or a non-finite value (the weight included).
    """
    if len(targets) != len(ARM_SDK_JOINTS):
        raise ValueError(f"arm_sdk: expected {len(ARM_SDK_JOINTS)} motor commands, got {len(targets)}")
    if isinstance(weight, bool) or not isinstance(weight, int | float) or not math.isfinite(weight):
        raise ValueError(f"arm_sdk: weight must be a finite number, got {weight!r}")
    columns = tuple(zip(*map(_FIELDS, targets), strict=True))  # (q..., dq..., tau..., kp..., kd...)
    check_columns("arm_sdk", *columns)
    frame.set_columns(ARM_SDK_JOINTS, MOTOR_ENABLED, columns)
    frame.set_q(ARM_SDK_WEIGHT_INDEX, min(1.0, max(0.0, float(weight))))
    return frame


class ArmSdkWriter:
    """Publishes rt/arm_sdk frames (with CRC). Thread-safe."""

    def __init__(self, topic: str = topics.ARM_SDK) -> None:
        self.topic = topic
        self._lock = threading.Lock()
        self._frame = LowCmdFrame()
        self._writer = FrameWriter(topic)

    def write(self, targets: Sequence[MotorCommand], weight: float) -> None:
        with self._lock:
            build_arm_sdk_frame(self._frame, targets, weight)
            if not self._writer.write(self._frame):
                raise RobotError("arm_sdk", ERR_CLIENT_SEND, f"DDS write on {self.topic} failed")

    def close(self) -> None:
        with self._lock:
            self._writer.close()
