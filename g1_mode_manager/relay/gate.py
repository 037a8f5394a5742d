"""What a relay asks before forwarding: the mode machine's predicates, its forward gate and the link's health."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Protocol

from g1_mode_manager.core.machine.gate import ForwardDecision
from g1_mode_manager.core.modes import Mode

LeaveListener = Callable[[Mode, Mode], None]


class ModeGate(Protocol):
    """The subset of ModeMachine the relays use."""

    @property
    def mode(self) -> Mode: ...
    def allows_low_level_commands(self) -> bool: ...
    def holding_motion(self) -> bool:
        """A body check holds motion in the current mode (nothing but stopping passes)."""

    def forwarding(self, predicate: Callable[[Mode], bool]) -> AbstractContextManager[ForwardDecision]:
        """Held around one write: the decision (``allowed``, and the ``mode`` it judged, which the link check
        and a drop's reason take); no mode change or e-stop starts meanwhile. Never held while waiting for
        the robot's reply: wait after the block."""

    def add_leave_listener(self, listener: LeaveListener) -> None:
        """listener(source, target) runs after the gate closed, before the transition's first robot call."""


class LinkMonitor(Protocol):
    def link_ok(self, mode: Mode) -> bool:
        """Are the robot's state streams fresh enough to forward in ``mode`` (the one the gate judged)?"""
