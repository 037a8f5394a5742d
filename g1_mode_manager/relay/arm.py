"""~/arm_cmd -> rt/arm_sdk in HIGH_LEVEL: targets by joint name, blend weight ramped as far as the robot takes it."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence

from g1_mode_manager.core import modes
from g1_mode_manager.core.arm_ramp import ArmWeightRamp, robot_accepts_arm_sdk
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.joint_commands import JointCommandError, validate_arm_targets
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import MotorCommand, RobotError, RobotPort
from g1_mode_manager.core.watchdog import Watchdog
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS
from g1_mode_manager.relay.gate import LinkMonitor, ModeGate

#: Ramp-out waits (leaving HIGH_LEVEL, shutdown) give up this long after the ramp should have ended.
RAMP_OUT_MARGIN_S = 0.5


class ArmRelay:
    """Sends an rt/arm_sdk frame every tick while the weight is above zero.

    The weight is the one last written, and it follows what the robot can take: it ramps up only
    while arm commands arrive in HIGH_LEVEL *and* rt/sportmodestate shows the controller standing or
    walking; it restarts from 0 whenever the robot stopped accepting (it drops the blend itself).
    Targets are blended from the joint positions measured at ramp start; joints never named hold
    those. On link loss nothing is sent and the weight stays where it was (the robot holds it); on
    silence, on leaving HIGH_LEVEL and at shutdown it ramps back to 0.
    """

    def __init__(self, port: RobotPort, gate: ModeGate, link: LinkMonitor, events: RelayEvents, *,
                 ramp_time_s: float, silence_timeout_s: float, kp: float, kd: float, period_s: float,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._port = port
        self._gate = gate
        self._link = link
        self._events = events
        self._ramp = ArmWeightRamp(ramp_time_s, period_s)
        self._ramp_time_s = ramp_time_s
        self._watchdog = Watchdog(silence_timeout_s, clock)
        self._kp = kp
        self._kd = kd
        self._lock = threading.Lock()
        self._targets: dict[int, float] = {}  # guarded by _lock: the user's latest targets
        self._start: dict[int, float] = {}  # measured pose at ramp start (tick thread only)
        self._blend = 0.0  # how far targets moved from the start pose toward the user's (tick thread only)
        self._link_lost = False
        self._closing = threading.Event()  # shutdown: ramp out and stay out
        self._out_wanted = 0  # guarded by _cond: leave listeners waiting for the ramp-out
        self._abort = threading.Event()  # an e-stop: stop waiting for ramp-outs
        self._cond = threading.Condition()

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

    def busy(self) -> bool:
        """Frames to send soon: a weight above 0 (held, ramping) or arm commands arriving. Otherwise
        the worker may sleep until woken (a command, a mode change)."""
        return self._ramp.weight > 0.0 or not self._watchdog.expired()

    # --- ramp-out waits ------------------------------------------------------------------------
    def on_leave(self, source: Mode, target: Mode) -> None:
        """Leave listener: leaving HIGH_LEVEL ramps the arms out first (an e-stop never waits)."""
        if target is Mode.EMERGENCY:
            self._abort.set()
            with self._cond:
                self._cond.notify_all()
            return
        if source is Mode.HIGH_LEVEL:
            self._wait_out()

    def ramp_out(self) -> bool:
        """At shutdown: ramp to 0 and stay there; True once the robot was sent weight 0 (bounded wait)."""
        self._closing.set()
        return self._wait_out()

    def _wait_out(self) -> bool:
        deadline = time.monotonic() + self._ramp.weight * self._ramp_time_s * 2.0 + RAMP_OUT_MARGIN_S
        with self._cond:
            self._out_wanted += 1
            try:
                while self._ramp.weight > 0.0 and not self._abort.is_set() and not self._link_lost:
                    left = deadline - time.monotonic()
                    if left <= 0.0:
                        self._events.log("error", "arm_out_timeout",
                                         f"arm_sdk ramp-out incomplete: weight {self._ramp.weight:.2f} still held")
                        return False
                    self._cond.wait(left)
                return self._ramp.weight == 0.0
            finally:
                self._out_wanted -= 1

    # --- the frame loop ------------------------------------------------------------------------
    def tick(self, dt_s: float) -> None:
        try:
            self._tick(dt_s)
        finally:
            with self._cond:
                self._cond.notify_all()

    def _tick(self, dt_s: float) -> None:
        weight = self._ramp.weight
        if self._gate.mode is Mode.EMERGENCY:  # the e-stop's Damp owns the robot: no arm_sdk frame at all
            if weight > 0.0:
                self._restart(clear_targets=True)
            return
        if not self._link.link_ok():
            if weight > 0.0 and not self._link_lost:
                self._events.log("error", "arm_link",
                                 f"robot link lost: arm_sdk weight frozen at {weight:.2f} (the robot holds it)")
            self._link_lost = True
            return
        self._link_lost = False
        state = self._port.sport_state()
        if state is None or not robot_accepts_arm_sdk(state.fsm_id, state.fsm_mode):
            if weight > 0.0:
                fsm = None if state is None else state.fsm_id
                self._events.log("warn", "arm_not_accepted",
                                 f"robot fsm {fsm} does not take arm_sdk: weight restarts from 0")
            self._restart(clear_targets=False)
            return
        wanted = (not self._closing.is_set() and self._out_wanted == 0 and self._gate.allows_arm_commands()
                  and not self._watchdog.expired())
        if wanted:
            if weight == 0.0 and not self._capture_start():
                return
            with self._gate.forwarding(modes.allows_arm_commands) as allowed:
                if allowed:
                    self._send(True, dt_s)
                    return
        if weight > 0.0:
            with self._gate.ramping_out() as allowed:
                if allowed:
                    self._send(False, dt_s)

    def _send(self, engage: bool, dt_s: float) -> None:
        weight = self._ramp.propose(engage, dt_s)
        blend = max(self._blend, weight) if engage else self._blend
        with self._lock:
            targets = dict(self._targets)
        frame = [MotorCommand(q=self._start[m] + blend * (targets.get(m, self._start[m]) - self._start[m]),
                              kp=self._kp, kd=self._kd) for m in ARM_SDK_JOINTS]
        try:
            self._port.write_arm_sdk(frame, weight)
        except RobotError as exc:
            self._events.count("arm_write_failures")
            self._events.log("error", "arm_write", f"arm_sdk write failed: {exc}")
            return
        self._ramp.commit(weight)
        self._blend = blend
        self._events.count("arm_frames_sent")
        if weight == 0.0:
            self._restart(clear_targets=True)
            self._events.log("info", "arm_released", "arm_sdk weight 0 sent: arms handed back to the controller")

    def _capture_start(self) -> bool:
        q = self._port.joint_positions()
        if q is None:
            return False
        self._start = {m: float(q[m]) for m in ARM_SDK_JOINTS}
        self._blend = 0.0
        return True

    def _restart(self, *, clear_targets: bool) -> None:
        self._ramp.restart()
        self._blend = 0.0
        if clear_targets:
            with self._lock:
                self._targets.clear()
