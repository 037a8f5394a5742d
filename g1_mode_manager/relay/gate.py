"""What a relay asks before forwarding: the mode machine's predicates and the link's health."""

from __future__ import annotations

from typing import Protocol

from g1_mode_manager.core.modes import Mode


class ModeGate(Protocol):
    """The subset of ModeMachine the relays use."""

    @property
    def mode(self) -> Mode: ...
    def allows_cmd_vel(self) -> bool: ...
    def allows_arm_commands(self) -> bool: ...
    def allows_low_level_commands(self) -> bool: ...


class LinkMonitor(Protocol):
    def link_ok(self) -> bool: ...
