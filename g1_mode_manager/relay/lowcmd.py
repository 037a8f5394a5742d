"""~/lowcmd -> rt/lowcmd in LOW_LEVEL only; silence, link loss, a body check's hold, a released dead-man key
and leaving LOW_LEVEL turn into damping frames."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence

import numpy as np

from g1_mode_manager.core import modes
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.joint_commands import (
    DAMPING,
    JointCommandError,
    JointFrame,
    validate_lowcmd,
    validate_lowcmd_block,
)
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotError, RobotPort
from g1_mode_manager.core.watchdog import Watchdog
from g1_mode_manager.relay.gate import LinkMonitor, ModeGate

#: Damping frames written at once when LOW_LEVEL is left: more than one, so a lost frame does not leave
#: the robot's motor drivers holding the last user frame (they hold whatever came last).
EXIT_BURST = 3


class LowCmdRelay:
    """Each valid command is written at once (latest wins: no queue); `tick` damps on silence and link loss.

    The gate check and the write are one step under the machine's forward gate, so no user frame
    leaves after the mode left LOW_LEVEL or an e-stop began. On leaving LOW_LEVEL (``on_leave``)
    damping frames go out before the next mode's first robot call, and for ``exit_damping_s`` more
    when the robot stays in debug mode (IDLE), so the frame the drivers hold is a damping one. After an
    e-stop or a protective stop they go on until the high-level service is known active again
    (``service_active``): until then nothing else holds the robot. While LOW_LEVEL is held by a body check,
    and while the optional dead-man key (``deadman``) is released, damping frames replace the user's.
    """

    def __init__(self, port: RobotPort, gate: ModeGate, link: LinkMonitor, events: RelayEvents, *,
                 silence_timeout_s: float, exit_damping_s: float, service_active: Callable[[], bool],
                 deadman: Callable[[], bool] = lambda: True,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._service_active = service_active
        self._deadman = deadman
        self._port = port
        self._gate = gate
        self._link = link
        self._events = events
        self._watchdog = Watchdog(silence_timeout_s, clock)
        self._exit_damping_s = exit_damping_s
        self._clock = clock
        self._damp_until = 0.0
        self._released_at_stop = False  # a stop left LOW_LEVEL: damp until the service is known active
        self._lock = threading.Lock()

    def submit(self, names: Sequence[str], q: Sequence[float], dq: Sequence[float], tau: Sequence[float],
               kp: Sequence[float], kd: Sequence[float]) -> str | None:
        """Forward one joint command; returns an error text if refused."""
        return self._submit_checked(lambda: validate_lowcmd(names, q, dq, tau, kp, kd))

    def submit_block(self, names: Sequence[str], block: np.ndarray) -> str | None:
        """``submit`` with the five columns as one 5 x n array (q, dq, tau, kp, kd): the same checks, in numpy."""
        return self._submit_checked(lambda: validate_lowcmd_block(names, block))

    def _submit_checked(self, check: Callable[[], JointFrame]) -> str | None:
        self._events.count("lowcmd_received")
        try:
            frame = check()
        except JointCommandError as exc:
            self._events.count("lowcmd_rejected")
            self._events.log("warn", "lowcmd_rejected", f"lowcmd rejected: {exc}")
            return str(exc)
        return self.submit_frame(frame)

    def submit_frame(self, frame: JointFrame) -> str | None:
        """Forward one checked frame (a ``~/lowcmd`` message's, or a controller's in the node's own loop) under the
        same gate, link, dead-man and silence rules; returns an error text if it did not go out."""
        deadman = self._deadman()
        # the gate's decision is the only look at the mode: the link is judged for the mode it saw
        with self._gate.forwarding(modes.allows_low_level_commands) as decision:
            linked = decision.allowed and self._link.link_ok(decision.mode)
            if linked and deadman:
                self._watchdog.feed()
                return self._write(frame, "lowcmd_sent")
        if not decision.allowed:
            return self._drop(f"mode is {decision.mode.name}")
        if not linked:
            self._events.count("lowcmd_dropped")
            self._events.log("error", "lowcmd_link", "lowcmd dropped: robot link lost")
            return "robot link lost"
        self._events.count("lowcmd_deadman_released")
        self._write(DAMPING, "damping_frames_sent")
        return "dead-man key released: a damping frame was sent instead"

    def on_leave(self, source: Mode, target: Mode) -> None:
        """Leave listener of the mode machine: damp before the next mode's first robot call."""
        if source is not Mode.LOW_LEVEL:
            return
        self._watchdog.reset()
        sent = sum(self._write(DAMPING, "exit_damping_frames_sent") is None for _ in range(EXIT_BURST))
        if target is not Mode.HIGH_LEVEL:  # no SelectMode is under way or none has been seen to work yet
            with self._lock:
                self._damp_until = self._clock() + self._exit_damping_s
                self._released_at_stop = target in (Mode.EMERGENCY, Mode.FAULT)
        self._events.log("info", "lowcmd_exit", f"leaving LOW_LEVEL for {target.name}: {sent} damping frames sent")

    def end_stream(self) -> None:
        """The stream's source stopped on a fault of its own: react now as to silence (damping here; the user_ctrl
        relay's hold and hand-back), instead of after lowcmd_timeout_s more of the robot holding its last frame."""
        self._watchdog.reset()

    def at_exit(self) -> None:
        """Before the node stops its workers: nothing to do here (a silent stream already left damping frames)."""

    def busy(self) -> bool:
        """In LOW_LEVEL (damping on silence, link loss, a hold, a released dead-man) and while damping after
        leaving it is due; otherwise the worker may sleep until woken (a mode change)."""
        return self._gate.allows_low_level_commands() or self._held_in_low_level() or self._exit_damping_due()

    def _held_in_low_level(self) -> bool:
        return self._gate.mode is Mode.LOW_LEVEL and self._gate.holding_motion()

    def _exit_damping_due(self) -> bool:
        """Damping after leaving LOW_LEVEL: for exit_damping_s, and after a stop from LOW_LEVEL until the
        high-level service is known active (never after a stop from any other mode: the service holds the
        robot there, and a lowcmd frame would compete with it)."""
        mode = self._gate.mode
        with self._lock:
            due = self._clock() < self._damp_until
            released = self._released_at_stop
        if mode is Mode.IDLE:
            return due
        if mode not in (Mode.EMERGENCY, Mode.FAULT) or not released:
            return False
        if due or not self._service_active():
            return True
        with self._lock:
            self._released_at_stop = False  # the service answered: its Damp holds the robot from now on
        return False

    def tick(self, _dt_s: float) -> None:
        if self._gate.allows_low_level_commands():
            if self._watchdog.expired() or not self._link.link_ok(Mode.LOW_LEVEL) or not self._deadman():
                self._write(DAMPING, "damping_frames_sent")
            return
        if self._held_in_low_level():  # a body check holds motion: the user's controller is cut off
            self._write(DAMPING, "damping_frames_sent")
        elif self._exit_damping_due():
            self._write(DAMPING, "exit_damping_frames_sent")

    def _drop(self, why: str) -> str:
        self._events.count("lowcmd_dropped")
        self._events.log("warn", "lowcmd_dropped", f"lowcmd dropped: {why}, joint commands pass only in LOW_LEVEL")
        return why

    def _send(self, frame: JointFrame) -> None:
        """rt/lowcmd: the release path (the user_ctrl path's relay writes rt/user_lowcmd)."""
        self._port.write_lowcmd(frame)

    def _write(self, frame: JointFrame, counter: str) -> str | None:
        try:
            self._send(frame)
        except RobotError as exc:
            self._events.count("lowcmd_write_failures")
            self._events.log("error", "lowcmd_write", f"lowcmd write failed: {exc}")
            return str(exc)
        self._events.count(counter)
        return None
