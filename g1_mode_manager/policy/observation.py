"""A policy's observation as configuration: named terms, each of a fixed size and scaled, concatenated in the
deploy config's order into one preallocated float32 row (holosoma's ``obs_dict`` / ``obs_scales``, history 1).

The values of the terms come from the controller kind (a locomotion policy's gait phase and command, a tracking
policy's reference); the common ones (joints, IMU, last action) from :func:`common_terms`. The sim's walker
builds the same locomotion input in its own code: the sim shares only ``protocol/`` with the node, so the robot
stand-in never runs the product's code, and each checks the other.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from g1_mode_manager.core.controller.interface import ControllerError, RobotState
from g1_mode_manager.policy.deploy_config import ObservationSpec
from g1_mode_manager.protocol.motors import NUM_JOINTS

#: Every term a shipped kind can fill, with its size (holosoma's ``obs_dims``).
TERM_SIZES: Final = {
    "actions": NUM_JOINTS, "base_ang_vel": 3, "projected_gravity": 3, "dof_pos": NUM_JOINTS, "dof_vel": NUM_JOINTS,
    "command_lin_vel": 2, "command_ang_vel": 1, "sin_phase": 2, "cos_phase": 2,
    "motion_command": 2 * NUM_JOINTS, "motion_ref_ori_b": 6,
}


def projected_gravity(quat_wxyz: np.ndarray) -> np.ndarray:
    """Gravity's direction (0, 0, -1) in the body frame of orientation ``quat_wxyz``: R^T (0, 0, -1)."""
    w, x, y, z = quat_wxyz
    return -np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])


def common_terms(state: RobotState, default_pose: np.ndarray, last_action: np.ndarray) -> dict[str, np.ndarray]:
    return {"actions": last_action, "base_ang_vel": state.gyroscope, "projected_gravity":
            projected_gravity(state.quaternion_wxyz), "dof_pos": state.q - default_pose, "dof_vel": state.dq}


class ObservationBuilder:
    """Built once per policy (checked against the model's input size); ``build`` fills the same buffer each tick."""

    def __init__(self, spec: ObservationSpec, input_size: int, policy: str) -> None:
        unknown = [t for t in spec.terms if t not in TERM_SIZES]
        if unknown:
            raise ControllerError(f"policy {policy}: unknown observation terms {unknown}; known: "
                                  f"{', '.join(sorted(TERM_SIZES))}")
        bad_scales = [t for t in spec.scales if t not in spec.terms]
        if bad_scales:
            raise ControllerError(f"policy {policy}: scales given for terms it does not observe: {bad_scales}")
        size = sum(TERM_SIZES[t] for t in spec.terms)
        if size != input_size:
            raise ControllerError(f"policy {policy}: its observation terms make {size} values, the model's input "
                                  f"{spec.input!r} takes {input_size}")
        self.terms = spec.terms
        self._slots: list[tuple[str, slice, float]] = []
        at = 0
        for term in spec.terms:
            self._slots.append((term, slice(at, at + TERM_SIZES[term]), spec.scales.get(term, 1.0)))
            at += TERM_SIZES[term]
        self._row = np.zeros((1, size), dtype=np.float32)

    def build(self, values: dict[str, np.ndarray]) -> np.ndarray:
        row = self._row[0]
        for term, where, scale in self._slots:
            row[where] = values[term] if scale == 1.0 else np.asarray(values[term]) * scale
        return self._row
