"""When the autonomy may drive: only a robot that can see where it goes, stands free and walks when told to.

A planner steers by the robot's odometry; with a stale estimate it steers blind. A body check's hold stops all
motion anyway, and a robot that acknowledges Moves without walking (the walk judge) makes a planner push
harder into whatever holds it. Each is a reason to suspend the autonomy (the relay sends a StopMove) until the
condition clears; the teleop is not held by them beyond what already holds it (a human sees the robot).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.relay.walk_judge import WalkJudge


class AutonomyConditions:
    """``()`` -> why the autonomy may not drive now, or None."""

    def __init__(self, port: RobotPort, holds: Callable[[], tuple[str, ...]], walk: WalkJudge, *,
                 odom_timeout_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        if not odom_timeout_s > 0.0:
            raise ValueError(f"autonomy_odom_timeout_s must be > 0, got {odom_timeout_s}")
        self._port = port
        self._holds = holds
        self._walk = walk
        self._odom_timeout_s = odom_timeout_s
        self._clock = clock

    def __call__(self) -> str | None:
        odom = self._port.odometry()
        if odom is None:
            return "no odometry from the robot (rt/lf/odommodestate)"
        if odom.age_s > self._odom_timeout_s:
            return f"odometry {odom.age_s:.2f} s old (autonomy_odom_timeout_s {self._odom_timeout_s:g})"
        holds = self._holds()
        if holds:
            return f"a body check holds motion: {holds[0]}"
        warning = self._walk.report(self._clock()).warning
        if warning:
            return warning
        return None
