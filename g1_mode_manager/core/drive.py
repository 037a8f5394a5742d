"""Who drives in HIGH_LEVEL: the teleop (a human) or the autonomy (a planner), and the rules between them.

Driving is a sub-state of HIGH_LEVEL, not a mode of its own: the modes say what the robot obeys (LocoClient,
joint frames, damping), the driver says whose velocity commands the one Move stream carries. Outside
HIGH_LEVEL nobody drives. The rules:

- HIGH_LEVEL begins with the teleop driving.
- The autonomy drives only after an operator handed it the robot (``hand_over``); its commands before
  that are dropped.
- The human wins: a non-zero teleop command while the autonomy drives takes the robot back at once
  (``offer`` says so); so does ``take_over``, and leaving HIGH_LEVEL. Either way the autonomy needs a new
  hand-over. A zero teleop command (a joystick at rest publishes zeros) takes nothing.
- The autonomy going silent does not hand the robot to anyone: the relay stops the robot and the
  autonomy still drives, so its next command moves the robot again and nobody else's does.

Every change of driver bumps ``changes``: the relay then starts its ramp again from standstill, so that no
Move after the change carries the previous driver's velocity. Not thread-safe: its one user (relay/drive_sources.py) holds
its own lock around every call, and serialises a hand-over against mode changes (under the forward gate).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from g1_mode_manager.core.velocity import Velocity


class Driver(StrEnum):
    NOBODY = "nobody"  # outside HIGH_LEVEL
    TELEOP = "teleop"
    AUTONOMY = "autonomy"


@dataclass(frozen=True)
class Offer:
    """What became of a command offered by a source."""

    taken: bool  # it is now its source's latest command (its source drives)
    took_over: bool = False  # a teleop command that took the robot from the autonomy


class DriveArbiter:
    def __init__(self) -> None:
        self._autonomy = False  # handed over, and not taken back since
        self._changes = 0
        self._last_change = ""  # what the last change was, for ~/mode and the logs

    @property
    def driver(self) -> Driver:
        """Who drives while the mode is HIGH_LEVEL (the caller maps other modes to NOBODY)."""
        return Driver.AUTONOMY if self._autonomy else Driver.TELEOP

    @property
    def changes(self) -> int:
        return self._changes

    @property
    def last_change(self) -> str:
        return self._last_change

    def offer(self, source: Driver, v: Velocity) -> Offer:
        """A command from ``source`` (TELEOP or AUTONOMY): is it its driver's, and did it take over?"""
        if source is Driver.AUTONOMY:
            return Offer(taken=self._autonomy)
        if not self._autonomy:
            return Offer(taken=True)
        if v.is_zero():
            return Offer(taken=False)
        self._change(False, "taken over by a teleop command")
        return Offer(taken=True, took_over=True)

    def hand_over(self) -> bool:
        """The autonomy drives from now on; False if it did already."""
        if self._autonomy:
            return False
        self._change(True, "handed over to the autonomy")
        return True

    def take_over(self, why: str) -> bool:
        """The teleop drives from now on; False if it did already."""
        if not self._autonomy:
            return False
        self._change(False, why)
        return True

    def _change(self, autonomy: bool, why: str) -> None:
        self._autonomy = autonomy
        self._changes += 1
        self._last_change = why
