"""A stand-in that forwards to the current simulated robot, so the bridge can swap in a fresh one."""

from __future__ import annotations

from typing import Any


class RobotSlot:
    """Every part of the bridge (RPC handlers, frame intake, sim loop) holds this slot, not the robot.

    ``swap`` replaces the robot between two calls; a call already running finishes on the old one.
    """

    def __init__(self, robot: Any) -> None:
        object.__setattr__(self, "_robot", robot)

    def swap(self, robot: Any) -> None:
        object.__setattr__(self, "_robot", robot)

    @property
    def current(self) -> Any:
        return self._robot

    def __getattr__(self, name: str) -> Any:
        return getattr(self._robot, name)
