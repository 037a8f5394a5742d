"""Where the robot is when the sim starts: standing (the model's keyframe), folded in a squat, or lying on its back.

The vendor's power-on flows start from the last two (Unitree's remote-control guide as quoted in
phanthymotus-driver PR #215: powered on in the squat -> damp -> 706; powered on lying flat -> damp -> 702).
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Final

import mujoco

from g1_sim.physics.fold import FOLDED_PITCH_RAD, FOLDED_POSE
from g1_sim.physics.model import DEFAULT_POSE, G1Model
from g1_sim.physics.placement import place

#: Lying on the back: the policy's default pose (legs a little bent, arms a little forward) pitched back a quarter
#: turn. The first second of damping lays the limbs down.
LYING_PITCH_RAD: Final = -0.5 * math.pi


class BootPosture(Enum):
    STANDING = "standing"
    SQUAT = "squat"
    LYING = "lying"


def start_in(g1: G1Model, data: mujoco.MjData, posture: BootPosture) -> None:
    """Reset ``data`` to time 0 with the robot in ``posture`` on the floor at x = y = 0, facing +x, still."""
    g1.reset(data)
    if posture is BootPosture.STANDING:
        return
    pose, pitch = (FOLDED_POSE, FOLDED_PITCH_RAD) if posture is BootPosture.SQUAT else (DEFAULT_POSE, LYING_PITCH_RAD)
    data.qpos[:] = place(g1.model, pose, pitch).qpos
    mujoco.mj_forward(g1.model, data)
