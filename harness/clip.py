"""What a tracking policy's clip says of the robot it plays on, read from its model (as the node loads it): how long
the clip plays, how low its reference body goes (so that a judge of a fall can tell the clip's own crouch from a
robot on the floor), and the stiffness of the policy's own frames (to tell them on the sim's record from the
engage's and the hold's)."""

from __future__ import annotations

import sys
from functools import lru_cache
from pathlib import Path

import numpy as np


@lru_cache(maxsize=8)
def _controller(policy: str):
    from g1_mode_manager.node.settings import POLICY_MODELS
    from g1_mode_manager.policy.loader import load_policy
    from g1_mode_manager.policy.motion_tracking import MotionTrackingController

    controller = load_policy(policy, Path(sys.prefix) / POLICY_MODELS)
    if not isinstance(controller, MotionTrackingController):
        raise ValueError(f"{policy} is not a tracking policy")
    return controller


def clip_seconds(policy: str) -> float:
    """How long the clip plays after its start hold, s."""
    controller = _controller(policy)
    return controller.motion_steps / controller.rate_hz


def policy_kp_max(policy: str) -> float:
    """The largest kp of the policy's own frames."""
    return float(np.max(_controller(policy).policy_kp))


@lru_cache(maxsize=8)
def lowest_reference_m(policy: str) -> float:
    """The lowest the clip's reference body goes (``ref_pos_xyz``'s z over its every time step), m."""
    import onnxruntime as ort

    controller = _controller(policy)
    session = ort.InferenceSession(str(controller.model_path), providers=["CPUExecutionProvider"])
    width = {i.name: i.shape[1] for i in session.get_inputs()}["obs"]
    obs = np.zeros((1, width), dtype=np.float32)
    return min(float(session.run(["ref_pos_xyz"], {"obs": obs, "time_step": np.array([[t]], dtype=np.float32)})[0][0, 2])
               for t in range(controller.motion_steps + 1))
