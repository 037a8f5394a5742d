"""rt/lowcmd frames: all 29 motors commanded directly (only while the motion switcher is released)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

from g1_mode_manager.core.port import MotorCommand, RobotError
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.api_ids import ERR_CLIENT_SEND
from g1_mode_manager.protocol.motors import MODE_PR, MOTOR_ENABLED, NUM_JOINTS
from g1_mode_manager.sdk.frames import FrameWriter, LowCmdFrame, check_commands


def build_lowcmd_frame(frame: LowCmdFrame, commands: Sequence[MotorCommand], mode_machine: int) -> LowCmdFrame:
    """Fill ``frame``: motors 0..28 enabled with ``commands``, slots 29..34 left disabled, mode_pr 0.

    ``mode_machine`` must be the robot's (from rt/lowstate): the robot ignores a frame that differs.
    """
    check_commands("lowcmd", commands, NUM_JOINTS)
    if not 0 <= int(mode_machine) <= 0xFF:
        raise ValueError(f"lowcmd: mode_machine must fit uint8, got {mode_machine!r}")
    frame.set_header(MODE_PR, int(mode_machine))
    for index, command in enumerate(commands):
        frame.set_motor(index, MOTOR_ENABLED, command)
    return frame


class LowCmdWriter:
    """Publishes rt/lowcmd frames (with CRC), mode_machine from ``mode_machine()`` (None: no rt/lowstate yet).

    Thread-safe.
    """

    def __init__(self, mode_machine: Callable[[], int | None], topic: str = topics.LOWCMD) -> None:
        self.topic = topic
        self._mode_machine = mode_machine
        self._lock = threading.Lock()
        self._frame = LowCmdFrame()
        self._writer = FrameWriter(topic)

    def write(self, commands: Sequence[MotorCommand]) -> None:
        """Raises ValueError for bad commands, RobotError if no rt/lowstate was seen or the write failed."""
        check_commands("lowcmd", commands, NUM_JOINTS)
        mode_machine = self._mode_machine()
        if mode_machine is None:
            raise RobotError("lowcmd", ERR_CLIENT_SEND, "no rt/lowstate seen yet: mode_machine unknown")
        with self._lock:
            build_lowcmd_frame(self._frame, commands, mode_machine)
            if not self._writer.write(self._frame):
                raise RobotError("lowcmd", ERR_CLIENT_SEND, f"DDS write on {self.topic} failed")

    def close(self) -> None:
        with self._lock:
            self._writer.close()
