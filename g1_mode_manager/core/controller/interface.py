"""What a controller in the node's loop is: activated with the robot's measured state, stepped at its own rate
with the newest state sample and a velocity command, deactivated at the end; each step returns joint targets.

A controller never writes to the robot. Everything that decides what reaches it (the forward gate, the frame
checks shared with ``~/lowcmd``, the body checks, the e-stop, the hand-back) stays in the loop and the relay, so
a new policy is a model and a config, never a new path to the motors. Pure Python and numpy: no ROS, no DDS.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from g1_mode_manager.protocol.motors import NUM_JOINTS


class ControllerError(Exception):
    """A controller that cannot be loaded or stepped safely; the message says why (and names the joint)."""


@dataclass(frozen=True)
class RobotState:
    """One state sample as a controller reads it: motor order, rad, rad/s; the IMU of the pelvis."""

    q: np.ndarray  # (29,)
    dq: np.ndarray  # (29,)
    quaternion_wxyz: np.ndarray  # (4,)
    gyroscope: np.ndarray  # (3,) body frame, rad/s
    age_s: float  # how old the sample was when it was read

    @staticmethod
    def of(q: object, dq: object, quaternion_wxyz: object, gyroscope: object, age_s: float) -> RobotState:
        state = RobotState(np.asarray(q, dtype=float), np.asarray(dq, dtype=float),
                           np.asarray(quaternion_wxyz, dtype=float), np.asarray(gyroscope, dtype=float), age_s)
        if state.q.shape != (NUM_JOINTS,) or state.dq.shape != (NUM_JOINTS,):
            raise ControllerError(f"a state sample needs {NUM_JOINTS} joint positions and speeds")
        return state


@dataclass(frozen=True)
class JointTargets:
    """What a controller proposes for every motor (motor order): the robot's PD law
    tau_ff + kp (q - q_meas) + kd (dq - dq_meas)."""

    q: np.ndarray
    dq: np.ndarray
    tau: np.ndarray
    kp: np.ndarray
    kd: np.ndarray


@dataclass(frozen=True)
class Command:
    """The driver's velocity for a controller that walks (body frame: m/s, m/s, rad/s); others ignore it."""

    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0


@runtime_checkable
class Controller(Protocol):
    """The small interface of dm_control's controllers and ros2_control's lifecycle: configure once (the
    constructor: load and validate), then activate / step / deactivate any number of times."""

    name: str
    rate_hz: float
    #: the action scale and the rule that gave it (policy/action_scale.py), said at load and on the status
    action_scale_rule: str

    def activate(self, state: RobotState) -> None:
        """Start from the measured state (reset histories, the gait, the motion's clock)."""

    def step(self, state: RobotState, command: Command) -> JointTargets:
        """One tick; may raise ControllerError or anything else (the loop treats both as a fault)."""

    def deactivate(self) -> None:
        """Stop; nothing the controller holds reaches the robot after this."""

    def progress(self) -> float | None:
        """How far a finite motion has played, 0..1 (None for a controller that runs until stopped)."""

    def reference(self) -> np.ndarray | None:
        """The joint positions a tracking policy is following at this tick (its motion's frame), to judge how well
        the robot tracks it; None for a policy without a reference."""

    def reference_speeds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """What a tracking policy's motion asks at this tick: its joint speeds (rad/s, motor order) and how fast its
        reference body turns about each of its axes (rad/s, x y z), so that the speed checks do not take the motion
        for a flail; None for a policy without a motion."""

    def ready(self) -> JointTargets | None:
        """Where the robot must be before the first step, with the gains to hold it there (a tracking policy's
        first frame: the engage blends to it, then activates); None: the blend goes to the first steps' targets."""
