"""Stand-ins and helpers the relay tests share: the mode machine's gate, the Moves a fake port received, steps."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from g1_mode_manager.core.machine.gate import ForwardDecision
from g1_mode_manager.core.modes import Mode


class Gate:
    """Stands in for the mode machine: predicates, the forward gate and leave listeners.

    ``forward_refuses`` makes the forward gate say no although the predicates say yes: what a relay
    sees when an e-stop begins between its check and its send.
    """

    def __init__(self, mode: Mode) -> None:
        self.mode = mode
        self.in_transition = False
        self.forward_refuses = False
        self.forwarded = 0
        self.holds = False
        self.listeners: list[Callable[[Mode, Mode], None]] = []

    def _is(self, mode: Mode) -> bool:
        return self.mode is mode and not self.in_transition

    def allows_low_level_commands(self) -> bool:
        return self._is(Mode.LOW_LEVEL) and not self.holds

    def holding_motion(self) -> bool:
        return self.holds

    @contextmanager
    def forwarding(self, predicate: Callable[[Mode], bool]) -> Iterator[ForwardDecision]:
        ok = predicate(self.mode) and not self.in_transition and not self.holds and not self.forward_refuses
        self.forwarded += ok
        yield ForwardDecision(ok, self.mode)

    def add_leave_listener(self, listener: Callable[[Mode, Mode], None]) -> None:
        self.listeners.append(listener)

    def leave(self, target: Mode) -> None:
        """What the machine does on a mode change: close the gate, tell the listeners, change the mode."""
        source, self.in_transition = self.mode, True
        for listener in self.listeners:
            listener(source, target)
        self.mode, self.in_transition = target, False


def moves(port) -> list[tuple]:
    """The arguments of every Move (SetVelocity) the fake robot port received."""
    return [s.args for s in port.stream("set_velocity")]


def run_steps(relay, clock, n: int, dt: float) -> None:
    """``n`` sender steps, the fake clock advanced ``dt`` before each."""
    for _ in range(n):
        clock.advance(dt)
        relay.step()
