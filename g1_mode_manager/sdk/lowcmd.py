"""rt/lowcmd frames: all 29 motors commanded directly (only while the motion switcher is released)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

from unitree_sdk2py.core.channel import ChannelPublisher

from g1_mode_manager.core.port import MotorCommand, RobotError
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.api_ids import ERR_CLIENT_SEND
from g1_mode_manager.protocol.crc import lowcmd_crc
from g1_mode_manager.protocol.idl import LowCmd_
from g1_mode_manager.protocol.motors import MODE_PR, MOTOR_ENABLED, NUM_JOINTS
from g1_mode_manager.sdk.frames import check_commands, fill_motor, new_lowcmd


def build_lowcmd_frame(msg: LowCmd_, commands: Sequence[MotorCommand], mode_machine: int) -> LowCmd_:
    """Fill ``msg``: motors 0..28 enabled with ``commands``, slots 29..34 left disabled, mode_pr 0, CRC.

    ``mode_machine`` must be the robot's (from rt/lowstate): the robot ignores a frame that differs.
    """
    check_commands("lowcmd", commands, NUM_JOINTS)
    if not 0 <= int(mode_machine) <= 0xFF:
        raise ValueError(f"lowcmd: mode_machine must fit uint8, got {mode_machine!r}")
    msg.mode_pr = MODE_PR
    msg.mode_machine = int(mode_machine)
    motors = msg.motor_cmd
    for index, command in enumerate(commands):
        fill_motor(motors[index], command, MOTOR_ENABLED)
    msg.crc = lowcmd_crc(msg)
    return msg


class LowCmdWriter:
    """Publishes rt/lowcmd frames with mode_machine from ``mode_machine()`` (None: no rt/lowstate yet).

    Creating it costs the SDK writer's 0.2 s sleep. Thread-safe.
    """

    def __init__(self, mode_machine: Callable[[], int | None], topic: str = topics.LOWCMD) -> None:
        self.topic = topic
        self._mode_machine = mode_machine
        self._lock = threading.Lock()
        self._msg = new_lowcmd()
        self._publisher = ChannelPublisher(topic, LowCmd_)
        self._publisher.Init()

    def write(self, commands: Sequence[MotorCommand]) -> None:
        """Raises ValueError for bad commands, RobotError if no rt/lowstate was seen or the write failed."""
        check_commands("lowcmd", commands, NUM_JOINTS)
        mode_machine = self._mode_machine()
        if mode_machine is None:
            raise RobotError("lowcmd", ERR_CLIENT_SEND, "no rt/lowstate seen yet: mode_machine unknown")
        with self._lock:
            msg = build_lowcmd_frame(self._msg, commands, mode_machine)
            if not self._publisher.Write(msg):
                raise RobotError("lowcmd", ERR_CLIENT_SEND, f"DDS write on {self.topic} failed")

    def close(self) -> None:
        self._publisher.Close()
