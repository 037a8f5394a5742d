"""rt/lowcmd, rt/user_lowcmd and rt/arm_sdk intake: check each frame as the robot does, count the ignored ones
by reason.

rt/lowcmd (debug mode only): a frame whose CRC is wrong or whose ``mode_machine`` is not the robot's
(5) is ignored; motors whose ``mode`` is not 1 are disabled (no torque). In user control it is ignored
(``user_ctrl_active``): the joints are rt/user_lowcmd's.

rt/user_lowcmd (user control only, newer firmware): checked as rt/lowcmd (CRC, ``mode_machine``, motor
``mode``); outside user control, the switch's delay included, ignored (``not_user_ctrl``). Unitree's app
template computes its CRC; its SDK example leaves CRC, ``mode_machine`` and ``mode`` at 0, and the sim takes
the stricter reading (docs/robot_compat.md, "User control").

rt/arm_sdk (built-in controller standing or walking): neither the CRC nor ``mode_machine`` nor the motor
``mode`` flags are checked. Unitree's own arm_sdk examples leave all three at 0 and work on the robot: the
C++ ``g1_arm7_sdk_dds_example`` (and the ROS 2 one) never compute a CRC, and the SDK's own ``ArmSdk``
publisher (dds_wrapper ``g1_pub.h``) has no CRC step where its ``LowCmd`` publisher has one. So the
controller that reads rt/arm_sdk does not look at the field at all, and a non-zero wrong CRC passes as
well as 0. Both are counted (``crc0``, ``crc_wrong``), as are frames with another ``mode_machine`` than 5
(``mode_machine_not_5``), so a test can still see them. ``motor_cmd[29].q`` is the blend weight, clipped to
0..1. Frames with a non-finite number are ignored on both topics (``non_finite``).
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from collections.abc import Callable
from operator import attrgetter
from typing import Any, Final, Protocol

import numpy as np

from g1_mode_manager.protocol.crc import lowcmd_crc
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS
from g1_mode_manager.protocol.idl import LowCmd_
from g1_mode_manager.protocol.motors import (
    ARM_SDK_JOINTS,
    ARM_SDK_WEIGHT_INDEX,
    JOINT_RANGE_RAD,
    MODE_MACHINE_G1_29DOF,
    MOTOR_ENABLED,
    NUM_JOINTS,
)

LOWCMD: Final = "lowcmd"
USER_LOWCMD: Final = "user_lowcmd"
ARM_SDK: Final = "arm_sdk"

# Reasons a frame is ignored (counters; "received" and "accepted" count the rest).
BAD_CRC: Final = "bad_crc"
BAD_MODE_MACHINE: Final = "bad_mode_machine"
NON_FINITE: Final = "non_finite"
NOT_DEBUG_MODE: Final = "not_debug_mode"  # lowcmd while the sport service owns the motors
NOT_STANDING: Final = "not_standing"  # arm_sdk while the controller neither stands nor walks
USER_CTRL_ACTIVE: Final = "user_ctrl_active"  # lowcmd while user control holds the joints
NOT_USER_CTRL: Final = "not_user_ctrl"  # user_lowcmd outside user control
DROPPED: Final = "dropped"  # arrived, never handled: the sim's handler fell too far behind (frame_reader.py)
# Informational (the frame still acts).
MODE_MACHINE_NOT_5: Final = "mode_machine_not_5"
MOTORS_DISABLED: Final = "motors_disabled"
ARM_SDK_CRC0: Final = "crc0"  # rt/arm_sdk frame without a CRC (the field left 0)
ARM_SDK_CRC_WRONG: Final = "crc_wrong"  # rt/arm_sdk frame whose non-zero CRC is wrong

# The frame's crc field, as the record shows it.
CRC_OK: Final = "ok"
CRC_NONE: Final = "none"  # 0 (and the content's CRC is not 0)
CRC_WRONG: Final = "wrong"

_MOTOR: Final = attrgetter("mode", "q", "dq", "tau", "kp", "kd")
#: on_frame(topic, reason ignored or None, arm_sdk weight, largest kp, its crc field as CRC_OK / CRC_NONE /
#: CRC_WRONG, when it arrived (None: not known), its arrival number on the topic (None: not known), when its writer
#: wrote it (None: not known), how far its furthest position target lies past its joint's range (rad, 0 within)):
#: for the sim's record, called once the frame is applied (or ignored).
FrameHook = Callable[[str, "str | None", float, float, str, "float | None", "int | None", "float | None", float],
                     None]
_LOWEST: Final = np.array([low for low, _ in JOINT_RANGE_RAD])
_HIGHEST: Final = np.array([high for _, high in JOINT_RANGE_RAD])


def past_range(q: np.ndarray, joints: range | tuple[int, ...]) -> float:
    """How far the furthest of ``q`` (targets of ``joints``) lies outside its joint's range, rad (0: all within;
    NaN stays NaN)."""
    index = list(joints)
    return float(max(0.0, np.max(np.maximum(q - _HIGHEST[index], _LOWEST[index] - q))))


def crc_state(field: int, content: int) -> str:
    """How a frame's crc field relates to the CRC of its content."""
    if field == content:
        return CRC_OK
    return CRC_NONE if field == 0 else CRC_WRONG


class CommandRobot(Protocol):
    def sport_active(self) -> bool: ...
    def sport_state(self) -> tuple[int, int]: ...
    @property
    def standing_balanced(self) -> bool: ...
    def apply_arm_sdk(self, q: Any, dq: Any, tau: Any, kp: Any, kd: Any, weight: float) -> None: ...
    def apply_lowcmd(self, q: Any, dq: Any, tau: Any, kp: Any, kd: Any, enabled: Any) -> None: ...
    def apply_user_lowcmd(self, q: Any, dq: Any, tau: Any, kp: Any, kd: Any, enabled: Any) -> bool: ...
    @property
    def user_ctrl_active(self) -> bool: ...


def motor_arrays(msg: LowCmd_, indices: range | tuple[int, ...]) -> np.ndarray:
    """(6, n) array of mode, q, dq, tau, kp, kd for the given motor indices."""
    cmds = msg.motor_cmd
    return np.array([_MOTOR(cmds[i]) for i in indices], dtype=np.float64).T


class CommandIntake:
    """Checks, counts and applies LowCmd_ frames of both topics (called from DDS reader threads)."""

    def __init__(self, robot: CommandRobot, *, crc: Callable[[LowCmd_], int] = lowcmd_crc,
                 on_frame: FrameHook | None = None) -> None:
        self._robot = robot
        self._crc = crc
        self._on_frame = on_frame
        self._lock = threading.Lock()
        self._counts: dict[str, Counter[str]] = {LOWCMD: Counter(), USER_LOWCMD: Counter(), ARM_SDK: Counter()}
        self._last_frame_at = -math.inf  # CLOCK_MONOTONIC of the last frame of any topic

    def frames_within(self, seconds: float) -> bool:
        """A frame of any topic came in the last ``seconds`` (wall)."""
        return time.monotonic() - self._last_frame_at < seconds

    def _count(self, topic: str, *keys: str) -> None:
        with self._lock:
            counter = self._counts[topic]
            for key in keys:
                counter[key] += 1

    def on_dropped(self, topic: str, count: int) -> None:
        """``count`` frames of ``topic`` arrived and were never looked at."""
        with self._lock:
            self._counts[topic][DROPPED] += count

    def counts(self) -> dict[str, dict[str, int]]:
        with self._lock:
            return {topic: dict(sorted(c.items())) for topic, c in self._counts.items()}

    def on_lowcmd(self, msg: LowCmd_, at: float | None = None, n: int | None = None,
                  written: float | None = None) -> str | None:
        """Apply a rt/lowcmd frame that arrived at ``at`` as the topic's ``n``-th; returns the reason it was ignored,
        or None."""
        return self._on_joint_frame(LOWCMD, msg, self._apply_lowcmd, at, n, written)

    def _apply_lowcmd(self, m: np.ndarray, enabled: np.ndarray) -> str | None:
        if self._robot.user_ctrl_active:
            return USER_CTRL_ACTIVE
        if self._robot.sport_active():
            return NOT_DEBUG_MODE
        self._robot.apply_lowcmd(m[1], m[2], m[3], m[4], m[5], enabled)
        return None

    def on_user_lowcmd(self, msg: LowCmd_, at: float | None = None, n: int | None = None,
                       written: float | None = None) -> str | None:
        """Apply a rt/user_lowcmd frame as ``on_lowcmd``. The robot decides whether user control is in force (under
        its lock, so a frame never lands on the wrong side of the switch)."""
        return self._on_joint_frame(USER_LOWCMD, msg, self._apply_user_lowcmd, at, n, written)

    def _apply_user_lowcmd(self, m: np.ndarray, enabled: np.ndarray) -> str | None:
        return None if self._robot.apply_user_lowcmd(m[1], m[2], m[3], m[4], m[5], enabled) else NOT_USER_CTRL

    def _on_joint_frame(self, topic: str, msg: LowCmd_, apply: Callable[[np.ndarray, np.ndarray], str | None],
                        at: float | None, n: int | None, written: float | None = None) -> str | None:
        """A frame that drives all 29 motors: the robot's checks of any such frame, then ``apply`` (the topic's own
        rule, which applies the frame or says why not); counted, and recorded through ``on_frame``."""
        self._last_frame_at = time.monotonic()
        self._count(topic, "received")
        content = self._crc(msg)
        m = motor_arrays(msg, range(NUM_JOINTS))
        enabled = m[0] == MOTOR_ENABLED
        why = _check_motor_frame(msg, m, content)
        if why is None:
            why = apply(m, enabled)
        if why is None:
            self._count(topic, "accepted", *(() if enabled.all() else (MOTORS_DISABLED,)))
        else:
            self._ignore(topic, why)
        if self._on_frame is not None:
            self._on_frame(topic, why, 0.0, float(np.nanmax(m[4])), crc_state(int(msg.crc), content), at, n,
                           written, past_range(m[1], range(NUM_JOINTS)))
        return why

    def on_arm_sdk(self, msg: LowCmd_, at: float | None = None, n: int | None = None,
                   written: float | None = None) -> str | None:
        """Apply a rt/arm_sdk frame as ``on_lowcmd``."""
        self._last_frame_at = time.monotonic()
        content = self._crc(msg)
        crc = crc_state(int(msg.crc), content)
        self._count(ARM_SDK, "received", *{CRC_NONE: (ARM_SDK_CRC0,), CRC_WRONG: (ARM_SDK_CRC_WRONG,)}.get(crc, ()))
        weight = float(msg.motor_cmd[ARM_SDK_WEIGHT_INDEX].q)
        m = motor_arrays(msg, ARM_SDK_JOINTS)
        why = self._check_arm_sdk(m, weight)
        if why is None:
            self._robot.apply_arm_sdk(m[1], m[2], m[3], m[4], m[5], min(max(weight, 0.0), 1.0))
            extra = () if msg.mode_machine == MODE_MACHINE_G1_29DOF else (MODE_MACHINE_NOT_5,)
            self._count(ARM_SDK, "accepted", *extra)
        else:
            self._ignore(ARM_SDK, why)
        if self._on_frame is not None:
            self._on_frame(ARM_SDK, why, weight if math.isfinite(weight) else -1.0, float(np.nanmax(m[4])), crc, at, n,
                           written, past_range(m[1], ARM_SDK_JOINTS))
        return why

    def _check_arm_sdk(self, m: np.ndarray, weight: float) -> str | None:
        if not (math.isfinite(weight) and np.isfinite(m[1:]).all()):
            return NON_FINITE
        fsm_id, _ = self._robot.sport_state()
        robot = self._robot
        if not robot.sport_active() or fsm_id not in STANDING_FSM_IDS or not robot.standing_balanced:
            return NOT_STANDING
        return None

    def _ignore(self, topic: str, reason: str) -> str:
        self._count(topic, reason)
        return reason


def _check_motor_frame(msg: LowCmd_, m: np.ndarray, content: int) -> str | None:
    """The checks of a frame that drives all 29 motors (rt/lowcmd, rt/user_lowcmd)."""
    if msg.crc != content:  # the robot's motor side checks it (Unitree's low-level examples compute it)
        return BAD_CRC
    if msg.mode_machine != MODE_MACHINE_G1_29DOF:
        return BAD_MODE_MACHINE
    if not np.isfinite(m).all():
        return NON_FINITE
    return None
