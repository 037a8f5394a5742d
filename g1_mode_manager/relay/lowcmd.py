"""~/lowcmd -> rt/lowcmd in LOW_LEVEL only; silence turns into damping frames (kp 0, kd > 0)."""

from __future__ import annotations

from collections.abc import Sequence

from g1_mode_manager.core.joint_commands import JointCommandError, damping_frame, full_frame, validate_lowcmd
from g1_mode_manager.core.port import MotorCommand, RobotError, RobotPort
from g1_mode_manager.core.watchdog import Watchdog
from g1_mode_manager.relay.events import RelayEvents
from g1_mode_manager.relay.gate import LinkMonitor, ModeGate


class LowCmdRelay:
    """Each valid command is written at once (latest wins: no queue); `tick` damps on silence."""

    def __init__(self, port: RobotPort, gate: ModeGate, link: LinkMonitor, events: RelayEvents, *,
                 silence_timeout_s: float) -> None:
        self._port = port
        self._gate = gate
        self._link = link
        self._events = events
        self._watchdog = Watchdog(silence_timeout_s)

    def submit(self, names: Sequence[str], q: Sequence[float], dq: Sequence[float], tau: Sequence[float],
               kp: Sequence[float], kd: Sequence[float]) -> str | None:
        """Forward one joint command; returns an error text if refused."""
        self._events.count("lowcmd_received")
        if not self._gate.allows_low_level_commands():
            self._events.count("lowcmd_dropped")
            self._events.log("warn", "lowcmd_dropped",
                             f"lowcmd dropped: mode is {self._gate.mode.name}, joint commands pass only in LOW_LEVEL")
            return f"mode is {self._gate.mode.name}"
        if not self._link.link_ok():
            self._events.count("lowcmd_dropped")
            self._events.log("error", "lowcmd_link", "lowcmd dropped: robot link lost")
            return "robot link lost"
        try:
            targets = validate_lowcmd(names, q, dq, tau, kp, kd)
        except JointCommandError as exc:
            self._events.count("lowcmd_rejected")
            self._events.log("warn", "lowcmd_rejected", f"lowcmd rejected: {exc}")
            return str(exc)
        self._watchdog.feed()
        return self._write(full_frame(targets), "lowcmd_sent")

    def tick(self, _dt_s: float) -> None:
        if not self._gate.allows_low_level_commands():
            self._watchdog.reset()
            return
        if self._watchdog.expired() and self._link.link_ok():
            self._write(damping_frame(), "damping_frames_sent")

    def _write(self, frame: list[MotorCommand], counter: str) -> str | None:
        try:
            self._port.write_lowcmd(frame)
        except RobotError as exc:
            self._events.count("lowcmd_write_failures")
            self._events.log("error", "lowcmd_write", f"lowcmd write failed: {exc}")
            return str(exc)
        self._events.count(counter)
        return None
