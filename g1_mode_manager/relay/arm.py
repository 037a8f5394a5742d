"""~/arm_cmd -> rt/arm_sdk in HIGH_LEVEL: targets by joint name, blend weight ramped in and out."""

from __future__ import annotations

import threading
from collections.abc import Sequence

from g1_mode_manager.core.arm_ramp import ArmWeightRamp
from g1_mode_manager.core.joint_commands import JointCommandError, validate_arm_targets
from g1_mode_manager.core.port import MotorCommand, RobotError, RobotPort
from g1_mode_manager.core.watchdog import Watchdog
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS
from g1_mode_manager.relay.events import RelayEvents
from g1_mode_manager.relay.gate import LinkMonitor, ModeGate


class ArmRelay:
    """Sends an rt/arm_sdk frame every tick while the weight is above zero.

    The weight ramps toward 1 while arm commands arrive in HIGH_LEVEL, and back to 0 on silence, on
    leaving HIGH_LEVEL or on losing the link, so the built-in controller is never handed a jump.
    Joints never named hold the position they had when the ramp began.
    """

    def __init__(self, port: RobotPort, gate: ModeGate, link: LinkMonitor, events: RelayEvents, *,
                 ramp_time_s: float, silence_timeout_s: float, kp: float, kd: float) -> None:
        self._port = port
        self._gate = gate
        self._link = link
        self._events = events
        self._ramp = ArmWeightRamp(ramp_time_s)
        self._watchdog = Watchdog(silence_timeout_s)
        self._kp = kp
        self._kd = kd
        self._targets: dict[int, float] = {}
        self._lock = threading.Lock()

    @property
    def weight(self) -> float:
        return self._ramp.weight

    def submit(self, names: Sequence[str], positions: Sequence[float]) -> str | None:
        """Take arm targets; returns an error text if refused (nothing changes then)."""
        self._events.count("arm_cmd_received")
        if not self._gate.allows_arm_commands():
            self._events.count("arm_cmd_dropped")
            self._events.log("warn", "arm_dropped",
                             f"arm_cmd dropped: mode is {self._gate.mode.name}, arm commands pass only in HIGH_LEVEL")
            return f"mode is {self._gate.mode.name}"
        try:
            targets = validate_arm_targets(names, positions)
        except JointCommandError as exc:
            self._events.count("arm_cmd_rejected")
            self._events.log("warn", "arm_rejected", f"arm_cmd rejected: {exc}")
            return str(exc)
        with self._lock:
            self._targets.update(targets)
        self._watchdog.feed()
        return None

    def tick(self, dt_s: float) -> None:
        engage = self._gate.allows_arm_commands() and self._link.link_ok() and not self._watchdog.expired()
        was_idle = not self._ramp.active()
        if not engage and was_idle:
            return
        if engage and was_idle:
            self._capture_hold_pose()
        weight = self._ramp.step(engage, dt_s)
        with self._lock:
            frame = [MotorCommand(q=self._targets.get(m, 0.0), kp=self._kp, kd=self._kd) for m in ARM_SDK_JOINTS]
        try:
            self._port.write_arm_sdk(frame, weight)
        except RobotError as exc:
            self._events.count("arm_write_failures")
            self._events.log("error", "arm_write", f"arm_sdk write failed: {exc}")
            return
        self._events.count("arm_frames_sent")
        if weight == 0.0:
            with self._lock:
                self._targets.clear()
            self._events.log("info", "arm_released", "arm_sdk weight back at 0: arms handed back to the controller")

    def _capture_hold_pose(self) -> None:
        q = self._port.joint_positions()
        with self._lock:
            for m in ARM_SDK_JOINTS:
                if m not in self._targets and q is not None:
                    self._targets[m] = float(q[m])
