"""A velocity-commanded walking policy (holosoma's loco kind): gait phase and command in, joint targets out.

holosoma's locomotion deploy (policies/locomotion.py): the gait phase of each foot advances by one tick's share of
``gait_period_s`` before each inference; while the command is (near) zero the phase is held at (pi, pi) and the
robot stands; targets = default pose + action_scale * clip(action). The command is clamped to the ranges the model
was trained on (the node's own velocity limits apply before it gets here).
"""

from __future__ import annotations

from typing import Final

import numpy as np

from g1_mode_manager.core.controller.interface import Command, ControllerError, JointTargets, RobotState
from g1_mode_manager.policy.action_scale import ActionScale
from g1_mode_manager.policy.deploy_config import DeployConfig
from g1_mode_manager.policy.model import PolicyModel
from g1_mode_manager.policy.observation import ObservationBuilder, common_terms
from g1_mode_manager.protocol.motors import NUM_JOINTS

#: Below this command norm the policy is told to stand (phase held), as in holosoma.
STAND_COMMAND_NORM: Final = 0.01


class LocomotionController:
    def __init__(self, config: DeployConfig, model: PolicyModel, scale: ActionScale) -> None:
        self.name = config.name
        self.action_scale = scale.values
        self.action_scale_rule = scale.rule
        self.rate_hz = config.rate_hz
        self._config = config
        self._model = model
        inputs = model.inputs
        if config.observation.input not in inputs or len(inputs) != 1:
            raise ControllerError(f"policy {config.name}: the model takes {list(inputs)}, its config names "
                                  f"{config.observation.input!r} as its only input")
        self._output = next(iter(model.outputs))
        if model.outputs[self._output] != NUM_JOINTS:
            raise ControllerError(f"policy {config.name}: its output {self._output!r} has "
                                  f"{model.outputs[self._output]} values, not one per joint ({NUM_JOINTS})")
        self._obs = ObservationBuilder(config.observation, inputs[config.observation.input], config.name)
        self._phase_dt = 2 * np.pi / (config.rate_hz * config.gait_period_s)
        self._zeros = np.zeros(NUM_JOINTS)
        self._low = np.array([r[0] for r in config.command_ranges])
        self._high = np.array([r[1] for r in config.command_ranges])
        self.activate(None)

    def activate(self, state: RobotState | None) -> None:
        """Forget the last action and start the gait standing (left foot at 0, right at pi once it steps)."""
        self.last_action = np.zeros(NUM_JOINTS)
        self.phase = np.array([np.pi, np.pi])
        self._standing = True

    def deactivate(self) -> None:
        self.activate(None)

    def progress(self) -> float | None:
        return None

    def ready(self) -> None:
        return None

    def reference(self) -> None:
        return None

    def reference_speeds(self) -> None:
        return None

    def _advance_phase(self, command: np.ndarray) -> None:
        self.phase = np.fmod(self.phase + self._phase_dt + np.pi, 2 * np.pi) - np.pi
        if np.linalg.norm(command) < STAND_COMMAND_NORM:
            self.phase[:] = np.pi
            self._standing = True
        elif self._standing:
            self.phase = np.array([0.0, np.pi])
            self._standing = False

    def step(self, state: RobotState, command: Command) -> JointTargets:
        c = self._config
        cmd = np.clip(np.array([command.vx, command.vy, command.wz]), self._low, self._high)
        self._advance_phase(cmd)
        values = common_terms(state, c.default_pose, self.last_action)
        values.update(command_lin_vel=cmd[0:2], command_ang_vel=cmd[2:3], sin_phase=np.sin(self.phase),
                      cos_phase=np.cos(self.phase))
        obs = self._obs.build(values)
        action = self._model.run([self._output], {c.observation.input: obs})[0][0].astype(float)
        if not np.all(np.isfinite(action)):
            raise ControllerError(f"policy {self.name}: non-finite action from the model")
        self.last_action = np.clip(action, -c.action_clip, c.action_clip)
        return JointTargets(q=c.default_pose + self.action_scale * self.last_action, dq=self._zeros, tau=self._zeros,
                            kp=c.kp, kd=c.kd)
