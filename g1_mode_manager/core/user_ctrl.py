"""LOW_LEVEL by the firmware's user control: the choices, the robot calls it needs, and what the machine, the
lowcmd relay and the supervision share about it.

Two paths lead into LOW_LEVEL (``low_level_path``). ``release``: ReleaseMode, the robot limp in debug mode,
``~/lowcmd`` on ``rt/lowcmd``. ``user_ctrl`` (newer firmware): the robot is held by a hand-over frame at its
measured pose, SwitchToUserCtrl (7110), and only once GetFsmId shows 1000 is a user frame forwarded, on
``rt/user_lowcmd``; SwitchToInternalCtrl (7111) hands it back to its own controller. Pure Python: no ROS, no DDS.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Protocol, runtime_checkable

from g1_mode_manager.core.joint_commands import DAMPING, JointFrame
from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.protocol.fsm import InternalCtrl
from g1_mode_manager.protocol.motors import NUM_JOINTS


class LowLevelPath(StrEnum):
    USER_CTRL = "user_ctrl"  # SwitchToUserCtrl: the robot held throughout; needs newer firmware
    RELEASE = "release"  # ReleaseMode: the robot limp on entry and exit


class SilenceReaction(StrEnum):
    """What silence on ``~/lowcmd`` does on the user_ctrl path."""

    HAND_BACK = "hand_back"  # SwitchToInternalCtrl: WALKRUN when upright (-> IDLE), PASSIVE when not (-> FAULT)
    DAMP = "damp"  # damping frames on rt/user_lowcmd, as the release path does; the mode stays LOW_LEVEL


#: The refusal when the robot does not implement SwitchToUserCtrl (or does not answer it).
UNSUPPORTED = ("this firmware does not implement user control (3203); low_level_path: release enters LOW_LEVEL "
               "with the robot limp")

#: Upright enough for the walk-run controller to take the robot back: the limits of Unitree's app template
#: (deploy_template: SwitchToInternalCtrl PASSIVE past them, WALKRUN within), rad.
UPRIGHT_ROLL_RAD = 1.0
UPRIGHT_PITCH_RAD = 0.8
#: A hand-back decides WALKRUN or PASSIVE on the robot's last attitude no older than this, s. The state stream
#: stopping is itself a reason to hand back: a policy stops on a sample older than policy_state_timeout_s (0.05)
#: and its hand-back begins at once, so with a bound this far above that, a stream that stopped ends one way, the
#: way of the robot's last attitude: upright, the robot's own controller (it has its own IMU) takes it back standing;
#: tilted or unknown, PASSIVE and FAULT. Damping a robot that was upright a moment ago is what makes it fall.
HAND_BACK_ATTITUDE_S = 0.5


class UserCtrlRefused(Exception):  # noqa: N818 (named for the outcome, as Preempted)
    """The entry or an exit was refused with nothing left changed on the robot: the message is the answer."""


class NotUpright(Exception):  # noqa: N818
    """The robot is tilted past the template's limits: it goes PASSIVE and FAULT, not back to walking."""


@runtime_checkable
class UserCtrlPort(Protocol):
    """The robot calls of the user_ctrl path, beside the ModePort (sdk.robot.UnitreeRobot, the fakes)."""

    def switch_to_user_ctrl(self, timeout_s: float | None = None) -> None:
        """SwitchToUserCtrl (7110, ``{"data": false}``); raises RobotError with the robot's code."""

    def switch_to_internal_ctrl(self, target: InternalCtrl, timeout_s: float | None = None) -> None:
        """SwitchToInternalCtrl (7111, ``{"data": target}``)."""

    def write_user_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        """One rt/user_lowcmd frame (29 commands, CRC, mode_machine from rt/lowstate)."""

    def joint_positions(self) -> Sequence[float] | None: ...

    def attitude(self, max_age_s: float) -> tuple[float, float] | None:
        """(roll, pitch) of the pelvis IMU from the newest state sample, rad; None without one at most
        ``max_age_s`` old."""

    def joint_speed_max(self) -> float | None:
        """The largest |dq| of the newest state sample, rad/s; None without a fresh one."""


#: A SwitchToUserCtrl answered 0 after a stop began: the stop waits at most this long for its fsm 1000 before it damps
#: (s). The firmware does not cancel an accepted switch, and while one is pending Damp does nothing and GetFsmId
#: still shows the fsm from before it (docs/robot_compat.md): a robot damped before the switch would pass the
#: stop's verification and switch after it. Longer than switch_timeout_s, which a robot slower than the entry
#: expects (a loaded sim, a busy controller) may outlast.
LATE_SWITCH_WAIT_S = 5.0


@dataclass(frozen=True)
class UserCtrlConfig:
    """The user_ctrl path's parameters (node/settings.py holds their defaults and says why)."""

    switch_timeout_s: float = 1.0  # 7110 answered -> GetFsmId 1000 seen; 7111 answered -> another fsm seen
    poll_interval_s: float = 0.02  # GetFsmId while waiting for either
    hold_kp: float = 300.0  # the hand-over / hold frame's stiffness, N m/rad
    hold_kd: float = 8.0  # and damping, N m s/rad
    rest_speed_rad_s: float = 0.5  # the hand-over frame holds a pose: the robot must be at rest (every |dq| below)
    rest_timeout_s: float = 3.0  # how long the entry waits for rest after StopMove before it refuses
    #: the hand-over frame holds the robot this long after the entry for the user's first frame, before silence
    #: counts: a ROS publisher made just before the request needs 0.1-0.4 s to be matched and heard
    first_frame_s: float = 1.0
    silence: SilenceReaction = SilenceReaction.HAND_BACK


def roll_pitch(w: float, x: float, y: float, z: float) -> tuple[float, float]:
    """Roll and pitch (ZYX Euler angles) of an attitude quaternion (w, x, y, z), rad."""
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    return roll, pitch


def upright(attitude: tuple[float, float] | None) -> bool:
    """Within the template's limits; an unknown attitude is not upright (PASSIVE is the safe hand-back)."""
    return attitude is not None and abs(attitude[0]) <= UPRIGHT_ROLL_RAD and abs(attitude[1]) <= UPRIGHT_PITCH_RAD


def hold_frame(pose: Sequence[float], kp: float, kd: float) -> JointFrame:
    """Every joint held at ``pose`` (the measured one): what the robot gets while nothing of the user passes."""
    if len(pose) != NUM_JOINTS:
        raise ValueError(f"hold frame: expected {NUM_JOINTS} joint positions, got {len(pose)}")
    return JointFrame.of([MotorCommand(q=float(q), kp=kp, kd=kd) for q in pose])


class UserCtrlLink:
    """Whether the robot is, or may be about to be, under user control, and the frame that holds it meanwhile.

    ``live`` is set before SwitchToUserCtrl is sent and whenever fsm 1000 is seen; it is cleared only once the
    robot was seen out of user control after every switch it may still act on. While it is set and no user frame
    passes, the lowcmd relay writes ``filler`` to rt/user_lowcmd at its damping rate, so the robot is never
    without a command. ``live`` and ``filler`` are plain attributes: the e-stop reads them with nothing in front.
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._lock = threading.Lock()
        self.live = False
        self.filler: JointFrame = DAMPING
        self.entered_at = float("-inf")  # when fsm 1000 was seen by the entry (silence counts from there)
        self.left_at = float("-inf")  # when the robot was last seen out of user control by a verification
        self._switch_until = float("-inf")  # an accepted 7110 may still take effect until then
        #: Wakes whoever writes ``filler`` (the lowcmd relay's worker sleeps while it has nothing to send).
        self.wake: Callable[[], None] = lambda: None

    def begin(self, filler: JointFrame, stopped: Callable[[], bool]) -> bool:
        """The entry's hand-over: ``filler`` held from now on, unless ``stopped()`` (an e-stop or FAULT already
        preempted the entry); False then, nothing begun. Judged under the lock ``stop`` takes, so a stop either
        comes first and is seen here, or comes after and replaces the filler with damping."""
        with self._lock:
            if stopped():
                return False
            self.filler = filler
            self.live = True
        self.wake()
        return True

    def stop(self) -> None:
        """An e-stop or FAULT registered: whatever the relay repeats from now on is damping (nothing is repeated
        unless the robot is, or may be about to be, under user control)."""
        with self._lock:
            self.filler = DAMPING
        self.wake()

    def mark_live(self, filler: JointFrame | None = None) -> None:
        """fsm 1000 seen where it was not expected (a late switch): hold or damp the robot again."""
        with self._lock:
            if filler is not None:
                self.filler = filler
            self.live = True
        self.wake()

    def switch_sent(self) -> None:
        """7110 is on its way: until it is answered the robot may switch at any moment."""
        with self._lock:
            self._switch_until = float("inf")

    def switch_answered(self, window_s: float) -> None:
        """7110 answered 0: the robot may switch within ``window_s`` even if a stop saw another fsm first."""
        with self._lock:
            self._switch_until = self._clock() + window_s

    def entered(self) -> None:
        """fsm 1000 seen: the switch landed, nothing of it is still to come."""
        with self._lock:
            self.entered_at = self._clock()
            self._switch_until = float("-inf")

    def switch_pending_s(self) -> float:
        """How much longer an accepted 7110 may still take effect (0: none pending)."""
        with self._lock:
            return max(0.0, self._switch_until - self._clock())

    def left(self) -> bool:
        """The robot was seen out of user control: clear ``live`` unless an accepted switch may still land.
        True if cleared."""
        with self._lock:
            now = self._clock()
            if now < self._switch_until:
                return False
            self.live = False
            self.left_at = now
            return True

    def forget(self) -> None:
        """Nothing was switched (7110 refused or never sent)."""
        with self._lock:
            self.live = False
            self._switch_until = float("-inf")
