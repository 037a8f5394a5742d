"""What a relay asks before forwarding: the mode machine's predicates, its forward gate and the link's health."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Protocol

from g1_mode_manager.core.modes import Mode

LeaveListener = Callable[[Mode, Mode], None]


class ModeGate(Protocol):
    """The subset of ModeMachine the relays use."""

    @property
    def mode(self) -> Mode: ...
    def allows_cmd_vel(self) -> bool: ...
    def allows_arm_commands(self) -> bool: ...
    def allows_low_level_commands(self) -> bool: ...
    def holding_motion(self) -> bool:
        """A body check holds motion in the current mode (nothing but stopping passes)."""

    def forwarding(self, predicate: Callable[[Mode], bool]) -> AbstractContextManager[bool]:
        """Held around one write: True iff it may pass; no mode change or e-stop starts meanwhile. Never
        held while waiting for the robot's reply: wait after the block."""

    def ramping_out(self) -> AbstractContextManager[bool]:
        """Held around one hand-back frame: True unless an e-stop began (then nothing but damping is sent)."""

    def add_leave_listener(self, listener: LeaveListener) -> None:
        """listener(source, target) runs after the gate closed, before the transition's first robot call."""


class LinkMonitor(Protocol):
    def link_ok(self) -> bool: ...
