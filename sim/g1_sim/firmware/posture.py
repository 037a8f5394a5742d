"""How the robot's body lies, as the built-in controller needs to know it before a posture motion.

Pure Python on the pelvis height and IMU quaternion, so the firmware rules can be unit-tested without
physics. A G1 gets up from the floor only through lie-to-stand (702), from damping; a stand-up (4) or a
squat-to-stand (706) does not lift a lying robot, and 702 is meant for a robot lying on the floor.
"""

from __future__ import annotations

from enum import Enum
from typing import Final

import numpy as np

from g1_sim.firmware.state import tilt_rad

#: Lying: the pelvis tilted past the fall check's angle (terminations.hpp: 1.0 rad) and near the floor.
#: A damped G1 in the sim lies at about 0.08 m with a tilt of 1.8 rad; folded in a squat it leans 0.2-0.55 rad.
LYING_TILT_RAD: Final = 1.0
LYING_HEIGHT_M: Final = 0.45


class Posture(Enum):
    UPRIGHT = "upright"  # standing, squatting or sagging on its feet: not on the floor
    ON_BACK = "on_back"
    ON_FRONT = "on_front"

    @property
    def lying(self) -> bool:
        return self is not Posture.UPRIGHT


def posture_of(pelvis_z: float, quat_wxyz: np.ndarray) -> Posture:
    """Lying on its back when the body's x axis (forward) points up, on its front when it points down."""
    if pelvis_z >= LYING_HEIGHT_M or tilt_rad(quat_wxyz) <= LYING_TILT_RAD:
        return Posture.UPRIGHT
    w, x, y, z = (float(v) for v in quat_wxyz)
    forward_z = 2.0 * (x * z - w * y)  # world z of the body's x axis
    return Posture.ON_BACK if forward_z > 0.0 else Posture.ON_FRONT
