"""The robot's posture, read from its own state: the legs' joint angles, the pelvis' attitude and, where given,
a height estimate.

The built-in controller's fsm does not say how the body lies: damped or in zero torque the robot is limp, and
lying flat shows the same fsm as folded into a squat (phanthymotus-driver PR #215, on a G1); 706 squats a
standing robot down and stands a squatting one up, so its direction is the posture's. The posture verbs are
therefore answered and guarded on this reading (relay/loco_outcome.py, core/posture_guards.py).

What the joints cannot tell: a robot hanging from a gantry with its legs bent as they stood reads like a standing
one (the G1 reports no foot contact or load). A robot on straight legs reads as hanging only while limp (nothing
else keeps a limp robot upright); a limp robot on bent legs is falling or held up, which stays ``unknown``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from types import MappingProxyType
from typing import Final

from g1_mode_manager.core.body.readings import tilt_of
from g1_mode_manager.protocol.motors import JOINT_INDEX


class Posture(Enum):
    STANDING = "standing"
    SQUATTING = "squatting"
    SITTING = "sitting"
    LYING_BACK = "lying_back"
    LYING_FRONT = "lying_front"
    HANGING = "hanging"
    UNKNOWN = "unknown"

    @property
    def lying(self) -> bool:
        return self in (Posture.LYING_BACK, Posture.LYING_FRONT)


@dataclass(frozen=True)
class PostureLimits:
    """Where one posture ends and the next begins. Angles in rad (knee: 0 straight, positive bent; hip pitch:
    negative flexed forward), heights in m (pelvis above the floor). "Sim" sources are poses measured on the
    simulated G1 (Unitree's Menagerie model; docs/posture.md, scripts/measure_postures.py)."""

    #: Standing or hanging: the pelvis this close to vertical. Sim: standing, walking up to 1 m/s and a 150 N
    #: push stay under 0.07; the vendor's app template hands a robot back to damping past |pitch| 0.8.
    upright_tilt_rad: float = 0.5
    #: Lying: tilted past the fall check's angle (Unitree's terminations.hpp bad_orientation, 1.0 rad). Sim:
    #: damped on its back or front 1.33-1.86 (the fold tipped forward 1.33); an upright squat 0.04, sitting 0.06,
    #: the folded squat 0.24-0.54.
    lying_tilt_rad: float = 1.0
    #: Straight legs: both knees below this. Sim: a limp robot hanging in the gantry in zero torque -0.09; one
    #: knee of a walk at 1 m/s goes down to 0.16, never both.
    straight_knee_rad: float = 0.15
    #: Standing: both knees at most this bent. Sim: lock stand 0.67, walking 0.16-1.13, a push 1.17.
    standing_knee_rad: float = 1.3
    #: Squatting or sitting: both knees at least this bent. Sim: an upright squat 1.84, sitting 2.37, the folded
    #: squat 2.83-2.89; between 1.3 and 1.6 the robot is on its way (a squat's or stand-up's motion).
    folded_knee_rad: float = 1.6
    #: Sitting rather than squatting: both hips flexed past this (the thighs level), but not folded. Sim: sitting
    #: (fsm 3) -1.50; an upright squat (fsm 2) -0.92. No vendor source shows the G1's sit: the sim's is the only one.
    sitting_hip_rad: float = -1.3
    #: Folded: both hips flexed past this, the thighs against the trunk: the squat a G1 is powered on in and 706
    #: squats down to (the vendor's remote-control guide). Sim: 706's fold -2.15, damped -2.3 to -2.53 (the stop).
    folded_hip_rad: float = -1.8


LIMITS: Final = PostureLimits()

#: Where the pelvis may be for each posture, when a height estimate is given (outside: unknown). Sim: standing
#: 0.74-0.79 (0.85 lifted in the gantry), squatting 0.58 upright and 0.19-0.23 folded, sitting 0.40, lying
#: 0.06-0.20 (the fold tipped forward 0.20; the sim firmware's lying rule: below 0.45), hanging 0.76-0.79.
HEIGHT_BANDS_M: Final[Mapping[Posture, tuple[float, float]]] = MappingProxyType({
    Posture.STANDING: (0.55, 1.0),
    Posture.HANGING: (0.55, 2.0),
    Posture.SQUATTING: (0.1, 0.7),
    Posture.SITTING: (0.2, 0.55),
    Posture.LYING_BACK: (-0.1, 0.45),
    Posture.LYING_FRONT: (-0.1, 0.45),
})

_KNEES: Final = (JOINT_INDEX["left_knee_joint"], JOINT_INDEX["right_knee_joint"])
_HIPS: Final = (JOINT_INDEX["left_hip_pitch_joint"], JOINT_INDEX["right_hip_pitch_joint"])


@dataclass(frozen=True)
class PostureReading:
    """A posture and the tilt it was read at (None: no state sample, so nothing was read)."""

    posture: Posture
    tilt_rad: float | None = None

    def describe(self) -> str:
        """E.g. "squatting, tilt 0.04 rad"; "posture unknown (no state sample)"."""
        if self.tilt_rad is None:
            return "posture unknown (no state sample)"
        return f"{self.posture.value}, tilt {self.tilt_rad:.2f} rad"


NO_READING: Final = PostureReading(Posture.UNKNOWN)


def read_posture(q: Sequence[float], quaternion: tuple[float, float, float, float], *, limp: bool | None = None,
                 height_m: float | None = None, limits: PostureLimits = LIMITS) -> PostureReading:
    """The posture of a robot with joint positions ``q`` (motor order) and pelvis attitude ``quaternion`` (w, x, y,
    z). ``limp``: no controller holds the joints (damping or zero torque); None when not known. ``height_m``: the
    pelvis' height, when an estimate exists; a posture it contradicts reads as unknown."""
    if not all(map(math.isfinite, quaternion)) or not math.isfinite(tilt := tilt_of(*quaternion)):
        return NO_READING
    if len(q) <= max(_KNEES + _HIPS) or not all(math.isfinite(q[i]) for i in _KNEES + _HIPS):
        return PostureReading(Posture.UNKNOWN, tilt)
    posture = _posture(q, quaternion, tilt, limp, limits)
    band = HEIGHT_BANDS_M.get(posture)
    if height_m is not None and band is not None and not band[0] <= height_m <= band[1]:
        posture = Posture.UNKNOWN
    return PostureReading(posture, tilt)


def _posture(q: Sequence[float], quaternion: tuple[float, float, float, float], tilt: float, limp: bool | None,
             limits: PostureLimits) -> Posture:
    if tilt > limits.lying_tilt_rad:
        w, x, y, z = quaternion
        forward_up = 2.0 * (x * z - w * y)  # world z of the pelvis' forward axis: up when it lies on its back
        # on its side the sign decides: either way it lies, and lie_to_stand gets it up from both
        return Posture.LYING_BACK if forward_up >= 0.0 else Posture.LYING_FRONT
    knees = [q[i] for i in _KNEES]
    if min(knees) >= limits.folded_knee_rad:
        # bent legs carry the robot limp or not: a damped G1 rests in its folded squat (the power-on posture)
        hips = [q[i] for i in _HIPS]
        sitting = max(hips) <= limits.sitting_hip_rad and min(hips) > limits.folded_hip_rad
        return Posture.SITTING if sitting else Posture.SQUATTING
    if tilt > limits.upright_tilt_rad:
        return Posture.UNKNOWN  # falling, being lifted, or on its way up from the floor
    if max(knees) <= limits.straight_knee_rad:
        return Posture.HANGING if limp else Posture.UNKNOWN
    if max(knees) <= limits.standing_knee_rad:
        return Posture.UNKNOWN if limp else Posture.STANDING
    return Posture.UNKNOWN
