"""A pretrained 29-dof G1 locomotion policy (holosoma PPO or FastSAC, ONNX): observation in, joint targets out.

Layout verified against holosoma-inference 0.1.3 (``policies/base.py``, ``policies/locomotion.py``,
``config/config_values/observation.py``): the terms of ``actor_obs`` are concatenated in sorted name
order, each scaled, history length 1. The gait phase advances before each inference and is held at
(pi, pi) while the command is zero, so the robot stands still instead of stepping in place.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Final

import numpy as np
import onnxruntime as ort

from g1_mode_manager.protocol.motors import JOINT_NAMES, NUM_JOINTS
from g1_sim.physics.model import DEFAULT_POSE

RATE_HZ: Final = 50
ACTION_SCALE: Final = 0.25
GAIT_PERIOD_S: Final = 1.0
ANG_VEL_SCALE: Final = 0.25
DOF_VEL_SCALE: Final = 0.05
OBS_SIZE: Final = 100
#: Below this command norm the policy is told to stand (phase held), as in holosoma.
STAND_COMMAND_NORM: Final = 0.01


def projected_gravity(quat_wxyz: np.ndarray) -> np.ndarray:
    """Gravity direction (0, 0, -1) seen in the body frame of orientation ``quat_wxyz``."""
    w, x, y, z = quat_wxyz
    # Third row of the rotation matrix, negated: R^T @ (0, 0, -1).
    return -np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])


class LocomotionPolicy:
    """Stateful wrapper: call :meth:`act` at :data:`RATE_HZ`; it returns joint position targets (motor order)."""

    def __init__(self, onnx_path: str | Path) -> None:
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1  # a 2-core machine shared with the DDS bridge
        options.inter_op_num_threads = 1
        self._session = ort.InferenceSession(str(onnx_path), options, providers=["CPUExecutionProvider"])
        meta = self._session.get_modelmeta().custom_metadata_map
        names = tuple(json.loads(meta["dof_names"]))
        if names != JOINT_NAMES:
            raise ValueError(f"policy joint order differs from the G1 motor order: {names}")
        #: PD gains the policy was trained with, N m/rad and N m s/rad.
        self.kp = np.array(json.loads(meta["kp"]), dtype=float)
        self.kd = np.array(json.loads(meta["kd"]), dtype=float)
        self.command_ranges: dict[str, list[float]] = json.loads(meta.get("command_ranges", "{}"))
        self._input = self._session.get_inputs()[0].name
        self.default_pose = DEFAULT_POSE.copy()
        self._obs = np.zeros((1, OBS_SIZE), dtype=np.float32)
        self._phase_dt = 2 * np.pi / (RATE_HZ * GAIT_PERIOD_S)
        self.reset()

    def reset(self) -> None:
        """Forget the last action and restart the gait (left foot at 0, right at pi)."""
        self.last_action = np.zeros(NUM_JOINTS)
        self.phase = np.array([0.0, np.pi])
        self._standing = True

    def _advance_phase(self, command: np.ndarray, step_in_place: bool) -> None:
        self.phase = np.fmod(self.phase + self._phase_dt + np.pi, 2 * np.pi) - np.pi
        if np.linalg.norm(command) < STAND_COMMAND_NORM and not step_in_place:
            self.phase[:] = np.pi
            self._standing = True
        elif self._standing:
            self.phase = np.array([0.0, np.pi])
            self._standing = False

    def observation(self, q: np.ndarray, dq: np.ndarray, quat_wxyz: np.ndarray, ang_vel_body: np.ndarray,
                    command: np.ndarray) -> np.ndarray:
        """The 100-float ``actor_obs``: terms in name order (actions, base_ang_vel, command_ang_vel,
        command_lin_vel, cos_phase, dof_pos, dof_vel, projected_gravity, sin_phase)."""
        o = self._obs[0]
        o[0:29] = self.last_action
        o[29:32] = ang_vel_body * ANG_VEL_SCALE
        o[32] = command[2]
        o[33:35] = command[0:2]
        o[35:37] = np.cos(self.phase)
        o[37:66] = q - self.default_pose
        o[66:95] = dq * DOF_VEL_SCALE
        o[95:98] = projected_gravity(quat_wxyz)
        o[98:100] = np.sin(self.phase)
        return self._obs

    def act(self, q: np.ndarray, dq: np.ndarray, quat_wxyz: np.ndarray, ang_vel_body: np.ndarray,
            command: np.ndarray, *, step_in_place: bool = False) -> np.ndarray:
        """One 50 Hz tick: advance the phase, infer, return targets = default + 0.25 * action.

        ``command`` is (vx m/s, vy m/s, wz rad/s) in the body frame; ``step_in_place`` keeps the gait
        running at zero command (the firmware's continuous-gait balance mode).
        """
        command = np.asarray(command, dtype=float)
        self._advance_phase(command, step_in_place)
        obs = self.observation(q, dq, quat_wxyz, ang_vel_body, command)
        action = self._session.run(None, {self._input: obs})[0][0].astype(float)
        self.last_action = np.clip(action, -100.0, 100.0)
        return self.default_pose + ACTION_SCALE * self.last_action
