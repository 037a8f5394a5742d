"""Receive the robot's rt/lowstate only while something needs it.

rt/lowstate comes at 500 Hz; receiving it costs CPU in Cyclone's receive thread even with no Python per
sample. In HIGH_LEVEL nothing needs it unless the arms
are driven (their ramp starts from the measured pose) or joint_states are published: there the link's
evidence is rt/sportmodestate, the high-level service's own stream. A reboot silences that stream, and a
lost link subscribes again: the first sample after it is compared with the last one before (the reader
keeps it), so a tick that went back is seen as before. Every other mode (IDLE, LOW_LEVEL: mode_machine,
link health; EMERGENCY) and every transition receives it. It stops only after nothing needed it for
``hold_s``.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotPort

HOLD_S = 2.0


class LowStateDemand:
    def __init__(self, port: RobotPort, machine: ModeMachine, arms_busy: Callable[[], bool],
                 link_ok: Callable[[Mode], bool], *, always: bool, hold_s: float = HOLD_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._port = port
        self._machine = machine
        self._arms_busy = arms_busy
        self._link_ok = link_ok
        self._always = always
        self._hold_s = hold_s
        self._clock = clock
        self._last_needed = clock()

    def needed(self, target: Mode | None = None) -> bool:
        # the cheap answers first: every ~/arm_cmd (50 Hz) asks, and arms in play answer it at once
        if self._always or self._arms_busy() or (target is not None and target is not Mode.HIGH_LEVEL):
            return True
        status = self._machine.status()
        return status.mode is not Mode.HIGH_LEVEL or status.transition_in_progress or not self._link_ok(status.mode)

    def update(self, target: Mode | None = None) -> None:
        """Subscribe at once when needed (``target``: a transition about to start); unsubscribe after hold_s."""
        now = self._clock()
        if self.needed(target):
            self._last_needed = now
            self._port.set_lowstate_wanted(True)
        elif now - self._last_needed >= self._hold_s:
            self._port.set_lowstate_wanted(False)
