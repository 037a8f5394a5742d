"""/cmd_vel -> LocoClient Move, in HIGH_LEVEL only: sanitised, clamped, rate-limited, latest-wins, watchdog."""

from __future__ import annotations

import threading

from g1_mode_manager.core.port import RobotError, RobotPort
from g1_mode_manager.core.velocity import ZERO, RateLimiter, Sanitized, Velocity, VelocityLimits, sanitize
from g1_mode_manager.core.watchdog import Watchdog
from g1_mode_manager.relay.events import RelayEvents
from g1_mode_manager.relay.gate import LinkMonitor, ModeGate


class CmdVelRelay:
    """Keeps only the latest command; `tick` (called at a fixed rate) sends at most one Move.

    A slow RPC delays the next tick but never builds a queue. Silence longer than the watchdog
    timeout sends exactly one StopMove (SetVelocity 0, 0, 0); so does the gate closing while moving.
    """

    def __init__(self, port: RobotPort, gate: ModeGate, link: LinkMonitor, events: RelayEvents, *,
                 limits: VelocityLimits, timeout_s: float, move_duration_s: float) -> None:
        self._port = port
        self._gate = gate
        self._link = link
        self._events = events
        self._limits = limits
        self._limiter = RateLimiter(limits)
        self._watchdog = Watchdog(timeout_s)
        self._move_duration_s = move_duration_s
        self._target = ZERO
        self._lock = threading.Lock()
        self._moving = False  # the robot may be executing a non-zero Move we sent

    def submit(self, vx: float, vy: float, wz: float) -> Sanitized | None:
        """Take a new command from /cmd_vel; returns what will be sent, or None if dropped."""
        self._events.count("cmd_vel_received")
        if not self._gate.allows_cmd_vel():
            self._events.count("cmd_vel_dropped")
            mode = self._gate.mode.name
            self._events.log("warn", "cmd_vel_dropped",
                             f"cmd_vel dropped: mode is {mode}, velocity commands pass only in HIGH_LEVEL")
            return None
        result = sanitize(vx, vy, wz, self._limits)
        if result.rejected:
            self._events.count("cmd_vel_rejected")
            self._events.log("warn", "cmd_vel_rejected", f"{result.reason}: sending zero instead")
        elif result.clamped:
            self._events.count("cmd_vel_clamped")
            self._events.log("warn", "cmd_vel_clamped", result.reason)
        with self._lock:
            self._target = result.velocity
        self._watchdog.feed()
        return result

    def tick(self, dt_s: float) -> None:
        if not (self._gate.allows_cmd_vel() and self._link.link_ok()):
            self._watchdog.reset()
            with self._lock:
                self._target = ZERO
            if self._moving:
                self._stop_move("forwarding stopped")
            return
        if self._watchdog.expired():
            if self._moving:
                self._stop_move(f"no cmd_vel for {self._watchdog.timeout_s} s")
            return
        with self._lock:
            target = self._target
        velocity = self._limiter.step(target, dt_s)
        self._send(velocity)

    def _send(self, v: Velocity) -> None:
        try:
            self._port.set_velocity(v.vx, v.vy, v.wz, self._move_duration_s)
        except RobotError as exc:
            self._events.count("rpc_failures")
            self._events.log("error", "move_failed", f"Move failed: {exc}")
            return
        self._events.count("moves_sent")
        self._moving = not v.is_zero()

    def _stop_move(self, why: str) -> None:
        self._limiter.reset()
        self._moving = False
        try:
            self._port.set_velocity(0.0, 0.0, 0.0, self._move_duration_s)
        except RobotError as exc:
            self._events.count("rpc_failures")
            self._events.log("error", "stop_move_failed", f"StopMove ({why}) failed: {exc}")
            return
        self._events.count("stop_moves_sent")
        self._events.log("info", "stop_move", f"StopMove sent: {why}")
