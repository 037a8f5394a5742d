"""The folded squat: where 706 (StandUp2Squat) takes a standing G1, and one of the sim's boot postures.

A joint with kp 0 (damping, zero torque) holds still only against a stop or a contact, so a damped squat folds
until every leg pitch joint meets one, and stays on its feet only if its centre of mass is then over the feet.
An upright squat does not: its knees fold onto their stop, its hips do not, and it tips onto its back. This squat
has the knees and ankles near their stops and the trunk leaning forward, the centre of mass over the middle of
the feet; damped, the hips and waist fold onto their stops with the feet still under it. Figures, and how long
the model keeps it so: docs/robot_compat.md ("The damped squat, measured").
"""

from __future__ import annotations

from typing import Final

import numpy as np

from g1_mode_manager.protocol.motors import JOINT_RANGE_RAD
from g1_sim.physics.model import DEFAULT_POSE

#: How far inside its stop each folded joint's target stays, rad: a PD target on a hard stop pushes into it for
#: nothing; damping lets the joints settle the rest of the way.
STOP_MARGIN_RAD: Final = 0.05
_LEGS: Final = ((0, 3, 4), (6, 9, 10))  # hip pitch, knee, ankle pitch of each leg (motor order)
#: Hip pitch of the fold, rad: the trunk leans forward enough to bring the centre of mass over the middle of the
#: feet, short of the hips' stop (-2.53), where the trunk meets the thighs. Waist and arms keep the default pose.
FOLDED_HIP_PITCH_RAD: Final = -2.2


def _folded_pose() -> np.ndarray:
    low, high = np.array(JOINT_RANGE_RAD).T
    pose = DEFAULT_POSE.copy()
    for hip, knee, ankle in _LEGS:
        pose[hip] = FOLDED_HIP_PITCH_RAD
        pose[knee] = high[knee] - STOP_MARGIN_RAD  # fully bent
        pose[ankle] = low[ankle] + STOP_MARGIN_RAD  # the shin leaning forward as far as the ankle goes
    return pose


#: The folded squat's joint targets, motor order, rad.
FOLDED_POSE: Final = _folded_pose()
#: The pelvis's forward pitch with both feet flat on the floor in :data:`FOLDED_POSE`, rad (positive: leaning
#: forward). Hip, knee and ankle pitch turn about parallel axes, so the foot is pitched by their sum from the pelvis.
FOLDED_PITCH_RAD: Final = -float(FOLDED_POSE[0] + FOLDED_POSE[3] + FOLDED_POSE[4])
