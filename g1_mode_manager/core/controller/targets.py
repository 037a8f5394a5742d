"""A controller's targets as a frame for the robot: the very check a streamed ``~/lowcmd`` frame passes (finite,
within each joint's range, gains and torques within limits), so a policy never puts on the wire what a user's
controller could not."""

from __future__ import annotations

from g1_mode_manager.core.controller.interface import ControllerError, JointTargets
from g1_mode_manager.core.joint_commands import JointCommandError, JointFrame, validate_lowcmd
from g1_mode_manager.protocol.motors import JOINT_NAMES


def frame_of(targets: JointTargets) -> JointFrame:
    try:
        return validate_lowcmd(JOINT_NAMES, targets.q.tolist(), targets.dq.tolist(), targets.tau.tolist(),
                               targets.kp.tolist(), targets.kd.tolist())
    except JointCommandError as exc:
        raise ControllerError(f"target refused: {exc}") from exc
