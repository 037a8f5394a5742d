"""Loading a policy: its deploy config and model read and checked, then one probe inference on a standing robot
whose targets must pass the same frame check as a ``~/lowcmd`` frame. Any failure is a refusal that says why;
nothing is sent to the robot at load."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from g1_mode_manager.core.controller.interface import Command, Controller, ControllerError, RobotState
from g1_mode_manager.core.controller.targets import frame_of
from g1_mode_manager.policy.action_scale import resolve_action_scale, urdf_effort_limits
from g1_mode_manager.policy.deploy_config import parse_deploy_config, read_config, resolve_model
from g1_mode_manager.policy.locomotion import LocomotionController
from g1_mode_manager.policy.model import PolicyModel
from g1_mode_manager.protocol.motors import NUM_JOINTS


def load_policy(policy: str, model_dir: Path) -> Controller:
    name, raw = read_config(policy)
    model = PolicyModel(resolve_model(name, raw, model_dir))
    config = parse_deploy_config(raw, name=name, model=model.path, metadata=model.metadata)
    scale = resolve_action_scale(name, config.kind, config.action_scale, model.metadata, config.kp,
                                 urdf_effort_limits(name, model.metadata))
    if config.kind == "locomotion":
        controller: Controller = LocomotionController(config, model, scale)
    else:
        from g1_mode_manager.policy.motion_tracking import MotionTrackingController

        controller = MotionTrackingController(config, model, scale)
    _probe(controller, config.default_pose)
    return controller


def _probe(controller: Controller, pose: np.ndarray) -> None:
    """Two ticks on a robot standing still at the default pose, standing and walking: finite targets that the
    frame check passes, or the policy is refused."""
    state = RobotState.of(pose, np.zeros(NUM_JOINTS), (1.0, 0.0, 0.0, 0.0), np.zeros(3), 0.0)
    controller.activate(state)
    try:
        for command in (Command(), Command(vx=0.3)):
            frame_of(controller.step(state, command))
    except ControllerError as exc:
        raise ControllerError(f"policy {controller.name}: its probe inference was refused: {exc}") from exc
    finally:
        controller.deactivate()
