"""/cmd_vel judged on the robot: Moves the robot acknowledged, compared with how far its odometry says it went.

The robot answers SetVelocity with 0 in states where it does not walk (firmware quirks, a robot hung in a
gantry, feet off the ground), so an acknowledged Move is not a walking robot. While Moves worth walking for
are acknowledged, the robot's estimate (rt/lf/odommodestate, at each acknowledgement) is compared over the
last ``after_s``: a robot whose mean speed (distance and heading change over that window, so that a body
swaying in place does not count as walking) stays below a fifth of the command is reported. Without
odometry (old firmware) nothing is judged, and the report says so instead of guessing.
"""

from __future__ import annotations

import math
import threading
from collections import deque
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
    """``warning``: set while the robot acknowledges Moves but does not walk; ``judged``: odometry was there.
    ``commanded`` and ``measured``: (m/s, rad/s), the latter the mean over the last window."""

    warning: str | None
    judged: bool
    commanded: tuple[float, float] = (0.0, 0.0)
    measured: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class _Fix:
    at: float
    x: float
    y: float
    yaw: float  # unwrapped over the stretch


class WalkJudge:
    def __init__(self, after_s: float) -> None:
        if not after_s > 0:
            raise ValueError("not_walking_after_s must be > 0")
        self._after_s = float(after_s)
        self._lock = threading.Lock()
        self._fixes: deque[_Fix] = deque()  # the current stretch of judged acknowledgements
        self._since: float | None = None  # when the window first showed no walking
        self._last_ack = -math.inf
        self._judged = False
        self._commanded = (0.0, 0.0)
        self._measured = (0.0, 0.0)

    def acknowledged(self, vx: float, vy: float, wz: float, now: float, odom: OdomSample | None) -> None:
        """One Move the robot answered with 0, at ``now`` (monotonic), and the newest odometry then."""
        commanded = (math.hypot(vx, vy), abs(wz))
        with self._lock:
            gap = now - self._last_ack > ACK_FRESH_S
            self._last_ack, self._commanded = now, commanded
            fresh = odom is not None and odom.age_s <= ODOM_FRESH_S
            worth = _worth_judging(commanded)
            if gap or not fresh or not worth:  # a new stretch
                self._fixes.clear()
                self._since = None
            self._judged = fresh
            if odom is None or not fresh or not worth:
                return
            f = odom.fields
            yaw = f.rpy[2]
            if self._fixes:  # unwrap: a turn past +-pi must not look like a jump back
                yaw = self._fixes[-1].yaw + (yaw - self._fixes[-1].yaw + math.pi) % (2 * math.pi) - math.pi
            self._fixes.append(_Fix(now, f.position[0], f.position[1], yaw))
            while len(self._fixes) > 2 and now - self._fixes[1].at >= self._after_s:
                self._fixes.popleft()
            first = self._fixes[0]
            if now - first.at < self._after_s:
                return  # not a whole window yet
            dt = now - first.at
            measured = (math.hypot(f.position[0] - first.x, f.position[1] - first.y) / dt, abs(yaw - first.yaw) / dt)
            self._measured = measured
            if _walking(commanded, measured):
                self._since = None
            elif self._since is None:
                self._since = now

    def report(self, now: float) -> WalkReport:
        with self._lock:
            fresh = now - self._last_ack <= ACK_FRESH_S
            warning = None
            if fresh and self._since is not None:
                (cv, cw), (mv, mw) = self._commanded, self._measured
                warning = (f"{WARNING} (commanded {cv:.2f} m/s, {cw:.2f} rad/s; odometry shows {mv:.2f} m/s, "
                           f"{mw:.2f} rad/s over the last {self._after_s:g} s)")
            return WalkReport(warning, self._judged and fresh, self._commanded, self._measured)


def _worth_judging(commanded: tuple[float, float]) -> bool:
    return commanded[0] >= MIN_SPEED_MPS or commanded[1] >= MIN_YAW_RATE


def _walking(commanded: tuple[float, float], measured: tuple[float, float]) -> bool:
    (cv, cw), (mv, mw) = commanded, measured
    linear = cv >= MIN_SPEED_MPS and mv >= WALKING_FRACTION * cv
    turning = cw >= MIN_YAW_RATE and mw >= WALKING_FRACTION * cw
    return linear or turning
