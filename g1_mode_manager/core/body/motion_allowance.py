"""What a playing motion allows the speed checks: a dance's own speeds are not a flail, measured speed far beyond
them is.

The joint-speed and spin checks compare the robot's speeds with one threshold each (the vendor's 10 rad/s for any
joint, 6 rad/s for any axis of the pelvis gyro: terminations.hpp). That is right for a controller nobody knows the
intent of; a tracking policy says its intent each tick (the motion's joint speeds, the reference body's orientation),
and a dance asks joints for up to 30 rad/s and turns the body at 7 rad/s. So while a motion plays, each reading is
judged less what the motion allows:

- a joint may move as fast as the motion asked of it over the last ``REFERENCE_WINDOW_S`` (the robot lags its
  reference), plus ``JOINT_MARGIN`` of its own velocity limit (overshoot, and the jolt of a foot landing on an
  ankle), never faster than that limit (the G1's URDF: beyond it the motor no longer drives the joint);
- about each of its axes the body may turn as fast as the motion's reference body turned about it over the window,
  and half that again, plus ``SPIN_MARGIN_RAD_S`` (a dance spins about the vertical at 7 rad/s and the robot
  overshoots it; a fall tips about the others, which a dance seldom turns about fast).

A reading judged is the reading less the allowance, so the check's threshold and text are unchanged when nothing
plays, and a check trips while a dance plays when a joint moves ``JOINT_MARGIN`` of its limit faster than the dance
asks, or the body turns about an axis 1.5 times as fast as the dance's plus ``SPIN_MARGIN_RAD_S``.

The margins come from holosoma's two dances played on the sim with no latency (``bench.dance_playback``,
docs/policies.md "The body checks while a motion plays"): measured minus the window's largest reference reached 0.65
of a knee's limit for one 10 ms sample, 0.49 of the limit elsewhere; the pelvis turned about the vertical at up to
9.7 rad/s against the reference body's 7.1 (3.1 rad/s more than the window's largest), about the other axes at
most 5.1 rad/s, never past the vendor's 6.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final

import numpy as np

from g1_mode_manager.protocol.motors import JOINT_NAMES, NUM_JOINTS, VELOCITY_LIMIT_RAD_S

#: The motion's speeds count this long after the tick that asked for them, s.
REFERENCE_WINDOW_S: Final = 0.5
#: How far beyond the motion's speed a joint may move, as a share of its velocity limit.
JOINT_MARGIN: Final = 0.7
#: How much faster than the motion's reference body the body may turn about an axis: this share of its rate more,
#: and this many rad/s.
SPIN_SHARE: Final = 0.5
SPIN_MARGIN_RAD_S: Final = 3.0
_LIMITS: Final = np.array(VELOCITY_LIMIT_RAD_S)


@dataclass(frozen=True)
class MotionSpeeds:
    """The largest speeds a motion asked for over the window: per joint (rad/s, motor order) and the reference
    body's turning rate about each of its axes (rad/s, x y z)."""

    joints: np.ndarray
    body_rates: np.ndarray


@dataclass(frozen=True)
class Allowance:
    """How much more than the checks' base thresholds each joint and the body may move: rad/s, per joint (negative
    where the joint's velocity limit is below the base) and per gyro axis."""

    joints: tuple[float, ...]
    spin: tuple[float, float, float]


def allowance(joint_base_rad_s: float, spin_base_rad_s: float, motion: MotionSpeeds | None) -> Allowance:
    """What ``motion`` allows beyond the bases (a joint is never allowed past its velocity limit, motion or none)."""
    bounds = np.minimum(_LIMITS, joint_base_rad_s)
    spin = np.zeros(3)
    if motion is not None:
        bounds = np.minimum(_LIMITS, np.maximum(bounds, motion.joints + JOINT_MARGIN * _LIMITS))
        spin = np.maximum(0.0, (1.0 + SPIN_SHARE) * motion.body_rates + SPIN_MARGIN_RAD_S - spin_base_rad_s)
    x, y, z = spin.tolist()
    return Allowance(tuple((bounds - joint_base_rad_s).tolist()), (x, y, z))


NO_ALLOWANCE: Final = Allowance((0.0,) * NUM_JOINTS, (0.0, 0.0, 0.0))


def joint_detail(joint: int, speed: float, allowed: float, base_rad_s: float) -> str:
    """What the joint-speed check adds to its text when a motion or a joint's limit changed the joint's bound."""
    if joint < 0 or allowed == 0.0:
        return ""
    return f"{JOINT_NAMES[joint]} at {speed:.2f} rad/s, its bound {base_rad_s + allowed:.2f}"


class MotionRecord:
    """The speeds a tracking policy's motion asks for, as its ticks note them (the loop's thread, 50 Hz), turned
    there into what they allow beyond the checks' bases; ``current`` is read by the body watch's thread (100 Hz) and
    costs it no numpy: the allowance of the ticks of the last ``REFERENCE_WINDOW_S`` before the newest one, None once
    that is more than ``REFERENCE_WINDOW_S`` old (nothing is allowed beyond the bases)."""

    def __init__(self, joint_base_rad_s: float, spin_base_rad_s: float,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._bases = (joint_base_rad_s, spin_base_rad_s)
        self._clock = clock
        self._ticks: deque[tuple[float, np.ndarray, np.ndarray]] = deque()
        self._current: tuple[float, Allowance, MotionSpeeds] | None = None  # (newest tick, its allowance, speeds)

    def note(self, joint_speeds: np.ndarray, body_rates: np.ndarray) -> None:
        now = self._clock()
        self._ticks.append((now, np.abs(np.asarray(joint_speeds, dtype=float)).reshape(NUM_JOINTS),
                            np.abs(np.asarray(body_rates, dtype=float)).reshape(3)))
        while self._ticks[0][0] < now - REFERENCE_WINDOW_S:
            self._ticks.popleft()
        speeds = MotionSpeeds(np.max([j for _, j, _ in self._ticks], axis=0),
                              np.max([r for _, _, r in self._ticks], axis=0))
        self._current = (now, allowance(*self._bases, speeds), speeds)  # one reference: read whole by the other

    def current(self) -> Allowance | None:
        current = self._current
        if current is None or self._clock() - current[0] > REFERENCE_WINDOW_S:
            return None
        return current[1]

    def recent(self) -> MotionSpeeds | None:
        """The motion's largest speeds behind ``current`` (None likewise)."""
        current = self._current
        if current is None or self._clock() - current[0] > REFERENCE_WINDOW_S:
            return None
        return current[2]
