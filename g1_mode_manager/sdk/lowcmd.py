"""rt/lowcmd frames: all 29 motors commanded directly (only while the motion switcher is released)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

from g1_mode_manager.core.joint_commands import DAMPING, JointFrame
from g1_mode_manager.core.port import MotorCommand, RobotError
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.api_ids import ERR_CLIENT_SEND
from g1_mode_manager.protocol.motors import DAMPING_KD, MODE_PR, MOTOR_ENABLED, NUM_JOINTS
from g1_mode_manager.sdk.frames import FrameWriter, LowCmdFrame, check_block, check_columns, check_commands

_DAMPED = MotorCommand(kd=DAMPING_KD)


def build_lowcmd_frame(frame: LowCmdFrame, commands: Sequence[MotorCommand], mode_machine: int) -> LowCmdFrame:
    """Fill ``frame``: motors 0..28 enabled with ``commands``, slots 29..34 left disabled, mode_pr 0.

    ``commands`` may be a JointFrame (its columns go in as they are: the named joints, every other one
    damped). ``mode_machine`` must be the robot's (from rt/lowstate): the robot ignores a frame that differs.
    """
    if not 0 <= int(mode_machine) <= 0xFF:
        raise ValueError(f"lowcmd: mode_machine must fit uint8, got {mode_machine!r}")
    if not isinstance(commands, JointFrame):
        check_commands("lowcmd", commands, NUM_JOINTS)
        commands = JointFrame.of(commands)
    block = commands.block
    columns = (commands.q, commands.dq, commands.tau, commands.kp, commands.kd)
    if block is None:
        check_columns("lowcmd", *columns)
    else:
        check_block("lowcmd", block)
    frame.set_header(MODE_PR, int(mode_machine))
    if len(commands.indices) < NUM_JOINTS:
        frame.set_all(NUM_JOINTS, MOTOR_ENABLED, _DAMPED)
    if not commands.indices:
        return frame
    if block is None:
        frame.set_columns(commands.indices, MOTOR_ENABLED, columns)
    else:
        frame.set_block(commands.indices, MOTOR_ENABLED, block)
    return frame


class LowCmdWriter:
    """Publishes rt/lowcmd frames (with CRC), mode_machine from ``mode_machine()`` (None: no rt/lowstate yet).

    An all-damping frame depends on mode_machine alone: its bytes are made once per mode_machine, so
    LOW_LEVEL's damping frames (silence, link loss, holds, leaving LOW_LEVEL) cost one write each.
    Thread-safe.
    """

    def __init__(self, mode_machine: Callable[[], int | None], topic: str = topics.LOWCMD) -> None:
        self.topic = topic
        self._mode_machine = mode_machine
        self._lock = threading.Lock()
        self._frame = LowCmdFrame()
        self._writer = FrameWriter(topic)
        self._damping: dict[int, bytes] = {}

    def write(self, commands: Sequence[MotorCommand]) -> None:
        """Raises ValueError for bad commands, RobotError if no rt/lowstate was seen or the write failed."""
        mode_machine = self._mode_machine()
        if mode_machine is None:
            raise RobotError("lowcmd", ERR_CLIENT_SEND, "no rt/lowstate seen yet: mode_machine unknown")
        with self._lock:
            if commands is DAMPING:
                data = self._damping.get(mode_machine)
                if data is None:
                    data = self._damping[mode_machine] = self._writer.serialize(
                        build_lowcmd_frame(LowCmdFrame(), DAMPING, mode_machine))
                ok = self._writer.write_bytes(data)
            else:
                ok = self._writer.write(build_lowcmd_frame(self._frame, commands, mode_machine))
            if not ok:
                raise RobotError("lowcmd", ERR_CLIENT_SEND, f"DDS write on {self.topic} failed")

    def close(self) -> None:
        with self._lock:
            self._writer.close()
