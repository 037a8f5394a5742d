"""The Move stream's two sources and who of them drives: the teleop (/cmd_vel) and the autonomy (its own topic).

Commands are offered here by the command streams' thread; the cmd_vel sender picks the driver's latest
command at each step (``pick``). The rules of who drives are core/drive.py's; here they meet the commands,
the forward gate (a hand-over is decided under it, so no mode change comes between its check and the
change) and the autonomy's conditions (``blocked``: fresh odometry, no hold, a robot that walks when told to).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from g1_mode_manager.core import modes
from g1_mode_manager.core.drive import DriveArbiter, Driver
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.velocity import Sanitized, Velocity
from g1_mode_manager.relay.gate import ModeGate
from g1_mode_manager.relay.velocity_source import VelocitySource


@dataclass(frozen=True)
class Driving:
    """Who drives now and, while the autonomy does, why its commands do not move the robot ("" if they may)."""

    driver: Driver
    autonomy_suspended: str = ""
    autonomy_command: Velocity | None = None  # the autonomy's latest command while it drives


@dataclass(frozen=True)
class Pick:
    """What the sender's step takes: the driving source, its latest command, the commands taken since the
    last pick (of both sources), and whether the driver changed since then."""

    source: VelocitySource
    target: Velocity
    untaken: int
    new_driver: bool


class DriveSources:
    def __init__(self, gate: ModeGate, events: RelayEvents, teleop: VelocitySource, autonomy: VelocitySource | None,
                 *, blocked: Callable[[], str | None], wake: Callable[[], None]) -> None:
        self._gate = gate
        self._events = events
        self.teleop = teleop
        self.autonomy = autonomy
        self._blocked = blocked
        self._wake = wake  # the sender looks now
        self._arbiter = DriveArbiter()
        self._lock = threading.Lock()  # the arbiter, the sources' targets, the changes as the sender saw them
        self._changes_picked = 0
        #: called (in the thread that changed it) after each change of driver, e.g. to publish ~/mode at once
        self.on_driver_change: Callable[[], None] = lambda: None
        #: called with each command as it came (driver, vx, vy, wz) and whether it counts, e.g. by the flight recorder
        self.on_input: Callable[[Driver, float, float, float, bool], None] = lambda *_: None

    # --- commands ------------------------------------------------------------------------------
    def offer(self, source: VelocitySource, vx: float, vy: float, wz: float) -> Sanitized:
        """A command from ``source`` (never blocks): it counts only while its source drives, and a non-zero
        teleop command while the autonomy drives takes the robot back. Returns the sanitised command."""
        key = source.key
        self._events.count(f"{key}_received")
        result = source.sanitize(vx, vy, wz)
        if result.rejected:
            self._events.count(f"{key}_rejected")
            self._events.log("warn", f"{key}_rejected", f"{source.topic}: {result.reason}: sending zero instead")
        elif result.clamped:
            self._events.count(f"{key}_clamped")
            self._events.log("warn", f"{key}_clamped", f"{source.topic}: {result.reason}")
        with self._lock:
            offer = self._arbiter.offer(source.driver, result.velocity)
            if offer.took_over and self.autonomy is not None:
                self.autonomy.forget()
            look = offer.taken and source.take(result.velocity)
        self.on_input(source.driver, vx, vy, wz, offer.taken)
        if not offer.taken:
            self._events.count(f"{key}_ignored")
            if source is self.autonomy:
                self._events.log("warn", "autonomy_ignored", f"{source.topic} ignored: the autonomy has not been "
                                 "handed the robot (~/hand_over_to_autonomy, in HIGH_LEVEL)")
        if offer.took_over:
            self._events.count("teleop_takeovers")
            self._events.log("info", "teleop_takeover", "teleop took over from the autonomy: a non-zero cmd_vel")
            self.on_driver_change()
        if look or offer.took_over:
            self._wake()
        return result

    def pick(self) -> Pick:
        with self._lock:
            source = self.autonomy if self._arbiter.driver is Driver.AUTONOMY else self.teleop
            assert source is not None  # the arbiter hands over only when an autonomy input exists
            changes = self._arbiter.changes
            new_driver, self._changes_picked = changes != self._changes_picked, changes
            untaken = 0
            for each in self._each():
                untaken, each.untaken = untaken + each.untaken, 0
            return Pick(source, source.target, untaken, new_driver)

    def forget_all(self) -> None:
        """No command stands any more (forwarding stopped)."""
        with self._lock:
            for each in self._each():
                each.forget()

    def _each(self) -> tuple[VelocitySource, ...]:
        return (self.teleop,) if self.autonomy is None else (self.teleop, self.autonomy)

    # --- who drives ----------------------------------------------------------------------------
    def hand_over(self) -> tuple[bool, str]:
        """The autonomy drives from now on, if it can: HIGH_LEVEL, nothing holding motion, its conditions met."""
        autonomy = self.autonomy
        if autonomy is None:
            return False, "no autonomy input: the parameter autonomy_topic is empty"
        with self._gate.forwarding(modes.allows_cmd_vel) as decision:
            if not decision.allowed:
                why = (f"mode is {decision.mode.name}" if decision.mode is not Mode.HIGH_LEVEL
                       else "a body check holds motion (~/clear_fault)")
                return False, f"the autonomy drives only in HIGH_LEVEL with nothing held: {why}"
            blocked = self._blocked()
            if blocked is not None:
                return False, f"the autonomy cannot drive now: {blocked}"
            with self._lock:
                changed = self._arbiter.hand_over()
                if changed:
                    self.teleop.forget()
                    autonomy.forget()
        if not changed:
            return True, "the autonomy drives already"
        self._events.count("autonomy_handovers")
        self._events.log("info", "autonomy_handover", f"handed over to the autonomy ({autonomy.topic})")
        self.on_driver_change()
        self._wake()
        return True, f"the autonomy drives: commands on {autonomy.topic} move the robot"

    def take_over(self, why: str = "taken over by the operator") -> tuple[bool, str]:
        """The teleop drives from now on (the autonomy's Moves stop); it always can."""
        if not self._take_over(why):
            return True, "the teleop drives already"
        self._events.log("info", "teleop_takeover", f"teleop drives: {why}")
        self.on_driver_change()
        self._wake()
        return True, "the teleop drives; the autonomy needs a new hand-over"

    def left_high_level(self, target: Mode) -> None:
        """The autonomy needs a new hand-over in the next HIGH_LEVEL (a leave listener's part: no publishing)."""
        self._take_over(f"HIGH_LEVEL left for {target.name}")

    def _take_over(self, why: str) -> bool:
        with self._lock:
            changed = self._arbiter.take_over(why)
            if changed and self.autonomy is not None:
                self.autonomy.forget()
            return changed

    def driving(self, mode: Mode) -> Driving:
        """Who drives in ``mode`` (nobody outside HIGH_LEVEL) and why the autonomy's commands do not pass."""
        if mode is not Mode.HIGH_LEVEL:
            return Driving(Driver.NOBODY)
        with self._lock:
            driver = self._arbiter.driver
            command = None if self.autonomy is None else self.autonomy.target
        if driver is not Driver.AUTONOMY or self.autonomy is None:
            return Driving(driver)
        return Driving(driver, self.suspension(self.autonomy) or "", command)

    def blocked(self) -> str | None:
        """Why the autonomy may not drive now (its conditions), or None."""
        return self._blocked()

    def suspension(self, source: VelocitySource) -> str | None:
        """Why the autonomy's commands do not move the robot now: its conditions, or its silence; None if they
        may."""
        blocked = self._blocked()
        if blocked is not None:
            return f"suspended: {blocked}"
        if source.watchdog.age_s() is None:  # a hand-over forgets the commands from before it: none has come yet
            return f"waiting: no {source.topic} since the hand-over"
        if source.watchdog.expired():
            return f"silent: no {source.topic} for {source.watchdog.timeout_s:g} s"
        return None
