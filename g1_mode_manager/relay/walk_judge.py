"""/cmd_vel judged on the robot: Moves the robot acknowledged, compared with the speed its odometry shows.

The robot answers SetVelocity with 0 in states where it does not walk (firmware quirks, a robot hung in a
gantry, feet off the ground), so an acknowledged Move is not a walking robot. Each acknowledged Move is
compared with the newest rt/lf/odommodestate: a command worth walking for whose measured speed stays below
a fifth of it for longer than ``after_s`` is reported. Without odometry (old firmware) nothing is judged,
and the report says so instead of guessing.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Final

from g1_mode_manager.core.port import OdomSample

#: Commands below these are not worth judging (the robot may stand still for them).
MIN_SPEED_MPS: Final = 0.1
MIN_YAW_RATE: Final = 0.2
#: The measured speed must reach this fraction of the command to count as walking.
WALKING_FRACTION: Final = 0.2
#: Odometry older than this cannot judge a Move (the robot's rate is 20 Hz).
ODOM_FRESH_S: Final = 0.5
#: A judgement lapses once no Move was acknowledged for this long (the command stopped).
ACK_FRESH_S: Final = 1.0

WARNING: Final = "Moves acknowledged, robot not walking: is it in a walking fsm?"


@dataclass(frozen=True)
class WalkReport:
    """``warning``: set while the robot acknowledges Moves but does not walk; ``judged``: odometry was there."""

    warning: str | None
    judged: bool
    commanded: tuple[float, float] = (0.0, 0.0)  # (|v| m/s, |wz| rad/s)
    measured: tuple[float, float] = (0.0, 0.0)


class WalkJudge:
    def __init__(self, after_s: float) -> None:
        if not after_s > 0:
            raise ValueError("not_walking_after_s must be > 0")
        self._after_s = float(after_s)
        self._lock = threading.Lock()
        self._since: float | None = None  # first acknowledged Move of the current not-walking stretch
        self._last_ack = -math.inf
        self._judged = False
        self._commanded = (0.0, 0.0)
        self._measured = (0.0, 0.0)

    def acknowledged(self, vx: float, vy: float, wz: float, now: float, odom: OdomSample | None) -> None:
        """One Move the robot answered with 0, at ``now`` (monotonic), and the newest odometry then."""
        commanded = (math.hypot(vx, vy), abs(wz))
        with self._lock:
            self._last_ack = now
            self._commanded = commanded
            if odom is None or odom.age_s > ODOM_FRESH_S:
                self._judged, self._since = False, None
                return
            f = odom.fields
            measured = (math.hypot(f.velocity[0], f.velocity[1]), abs(f.yaw_speed))
            self._judged, self._measured = True, measured
            if _walking(commanded, measured) or not _worth_judging(commanded):
                self._since = None
            elif self._since is None:
                self._since = now

    def report(self, now: float) -> WalkReport:
        with self._lock:
            fresh = now - self._last_ack <= ACK_FRESH_S
            warning = None
            if fresh and self._since is not None and now - self._since >= self._after_s:
                (cv, cw), (mv, mw) = self._commanded, self._measured
                warning = (f"{WARNING} (commanded {cv:.2f} m/s, {cw:.2f} rad/s; odometry shows {mv:.2f} m/s, "
                           f"{mw:.2f} rad/s for {now - self._since:.1f} s)")  # fmt: skip
            return WalkReport(warning, self._judged and fresh, self._commanded, self._measured)


def _worth_judging(commanded: tuple[float, float]) -> bool:
    return commanded[0] >= MIN_SPEED_MPS or commanded[1] >= MIN_YAW_RATE


def _walking(commanded: tuple[float, float], measured: tuple[float, float]) -> bool:
    (cv, cw), (mv, mw) = commanded, measured
    linear = cv >= MIN_SPEED_MPS and mv >= WALKING_FRACTION * cv
    turning = cw >= MIN_YAW_RATE and mw >= WALKING_FRACTION * cw
    return linear or turning
