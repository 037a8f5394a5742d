"""What the body checks read: a few numbers per state sample, computed once from the robot's fields."""

from __future__ import annotations

import math
from dataclasses import dataclass
from operator import sub

from g1_mode_manager.core.body.motion_allowance import NO_ALLOWANCE, Allowance, joint_detail
from g1_mode_manager.protocol.body_fields import BodyFields


@dataclass(frozen=True)
class BodyReadings:
    """None: not known (no sample of that stream yet, or the robot does not publish it)."""

    tilt_rad: float | None = None  # angle between the body's z axis and vertical
    gyro_max: float | None = None  # largest |angular rate| of the three axes, rad/s
    joint_speed_max: float | None = None  # largest |dq|, rad/s
    joint_fastest: int = -1  # its motor index
    #: what the checks judge while a motion plays (core/body/motion_allowance.py): the largest |dq| less what the
    #: motion allows that joint, and the gyro less what it allows the body; the raw readings when nothing plays
    joint_speed_judged: float | None = None
    joint_judged: int = -1  # its motor index
    joint_judged_speed: float = 0.0  # its |dq|, rad/s
    joint_judged_allowed: float = 0.0  # what a motion (or its velocity limit) allowed it beyond the base, rad/s
    joint_base_rad_s: float = 0.0  # the joint-speed check's base bound
    gyro_judged: float | None = None

    @property
    def joint_speed_detail(self) -> str:
        """The joint-speed check's words on the joint it judged, when a motion or a joint's limit moved its bound
        (made only when a text is: not for every step)."""
        return joint_detail(self.joint_judged, self.joint_judged_speed, self.joint_judged_allowed,
                            self.joint_base_rad_s)
    winding_max_c: float | None = None
    winding_hottest: int = -1
    casing_max_c: float | None = None
    casing_hottest: int = -1
    soc_pct: float | None = None  # battery state of charge
    state_age_s: float | None = None  # age of the newest state sample (None: none ever came)


def tilt_of(w: float, x: float, y: float, z: float) -> float:
    """Angle between the body z axis and the world's vertical for an attitude quaternion (w, x, y, z)."""
    norm = w * w + x * x + y * y + z * z
    if norm <= 0.0:
        return math.nan
    cos_tilt = 1.0 - 2.0 * (x * x + y * y) / norm
    return math.acos(max(-1.0, min(1.0, cos_tilt)))


def readings_of(fields: BodyFields, *, state_age_s: float | None, soc_pct: float | None,
                allowance: Allowance = NO_ALLOWANCE, joint_base_rad_s: float = 0.0) -> BodyReadings:
    """Each maximum and where it is (the first motor holding it), and the speeds judged less ``allowance`` (the
    joint-speed check's base bound, ``joint_base_rad_s``, only words its text); C builtins over the tuples, as this
    runs for every body check (100 Hz)."""
    speeds = tuple(map(abs, fields.dq))
    fastest = speeds.index(max(speeds))
    judged = tuple(map(sub, speeds, allowance.joints))
    worst = judged.index(max(judged))
    gyro = max(map(abs, fields.gyroscope))
    gyro_judged = max(map(sub, map(abs, fields.gyroscope), allowance.spin))
    winding, casing = fields.winding_c, fields.casing_c
    hottest_winding = winding.index(max(winding))
    hottest_casing = casing.index(max(casing))
    return BodyReadings(
        tilt_rad=tilt_of(*fields.quaternion),
        gyro_max=gyro,
        joint_speed_max=speeds[fastest],
        joint_fastest=fastest,
        joint_speed_judged=judged[worst],
        joint_judged=worst,
        gyro_judged=gyro_judged,
        joint_judged_speed=speeds[worst],
        joint_judged_allowed=allowance.joints[worst],
        joint_base_rad_s=joint_base_rad_s,
        winding_max_c=float(winding[hottest_winding]),
        winding_hottest=hottest_winding,
        casing_max_c=float(casing[hottest_casing]),
        casing_hottest=hottest_casing,
        soc_pct=soc_pct,
        state_age_s=state_age_s,
    )
