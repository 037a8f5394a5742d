"""~/arm_cmd -> rt/arm_sdk in HIGH_LEVEL: targets by joint name, blend weight ramped as far as the robot takes it."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence

from g1_mode_manager.core import modes
from g1_mode_manager.core.arm_ramp import ArmWeightRamp, robot_accepts_arm_sdk
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.joint_commands import JointCommandError, validate_arm_targets
from g1_mode_manager.core.machine.gate import ForwardDecision
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
        self._targets: dict[int, float] = {}  # the user's latest targets, as the gate let them in (tick thread only)
        self._untaken: dict[int, float] = {}  # guarded by _lock: targets taken since the last frame's decision
        self._untaken_count = 0  # guarded by _lock: the commands that brought them
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
        """Take arm targets; returns an error text if invalid (nothing changes then).

        The mode is not asked here: the next frame's forward gate decides, and drops (and counts) the targets
        taken since the last frame when it refuses."""
        self._events.count("arm_cmd_received")
        try:
            targets = validate_arm_targets(names, positions)
        except JointCommandError as exc:
            self._events.count("arm_cmd_rejected")
            self._events.log("warn", "arm_rejected", f"arm_cmd rejected: {exc}")
            return str(exc)
        with self._lock:
            self._untaken.update(targets)
            self._untaken_count += 1
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
        # one decision per frame: whether to ramp in, hold, ramp out or send nothing follows from it
        with self._gate.forwarding(modes.allows_arm_commands) as decision:
            dropped = self._take_targets(decision.allowed)
            why_not = self._frame(decision, dt_s)
        if why_not is not None:  # logged after the gate: it covers the decision and the write only
            self._events.log(*why_not)
        if dropped:
            self._events.count("arm_cmd_dropped", dropped)
            self._events.log("warn", "arm_dropped", f"arm_cmd dropped: mode is {decision.mode.name}, "
                             "arm commands pass only in HIGH_LEVEL")

    def _take_targets(self, allowed: bool) -> int:
        """The targets taken since the last frame join the user's when the gate allows; otherwise they and
        their stream are forgotten. Returns how many commands were dropped."""
        with self._lock:
            count, self._untaken_count = self._untaken_count, 0
            if allowed:
                self._targets.update(self._untaken)
            self._untaken.clear()
        if allowed or not count:
            return 0
        self._watchdog.reset()
        return count

    def _frame(self, decision: ForwardDecision, dt_s: float) -> tuple[str, str, str] | None:
        """At most one frame, under the gate that judged ``decision``; returns a log line (level, key, text)
        saying why a weight above 0 could not be sent, if so."""
        weight = self._ramp.weight
        if decision.mode is Mode.EMERGENCY:  # the e-stop's Damp owns the robot: no arm_sdk frame at all
            if weight > 0.0:
                self._restart(clear_targets=True)
            return None
        if not self._link.link_ok(decision.mode):
            lost_now = weight > 0.0 and not self._link_lost
            self._link_lost = True
            return ("error", "arm_link", f"robot link lost: arm_sdk weight frozen at {weight:.2f} (the robot "
                    "holds it)") if lost_now else None
        self._link_lost = False
        state = self._port.sport_state()
        if state is None or not robot_accepts_arm_sdk(state.fsm_id, state.fsm_mode):
            self._restart(clear_targets=False)
            fsm = None if state is None else state.fsm_id
            return ("warn", "arm_not_accepted",
                    f"robot fsm {fsm} does not take arm_sdk: weight restarts from 0") if weight > 0.0 else None
        wanted = (decision.allowed and not self._closing.is_set() and self._out_wanted == 0
                  and not self._watchdog.expired())
        if wanted:
            if weight == 0.0 and not self._capture_start():
                return None
            self._send(True, dt_s)
        elif weight > 0.0 and modes.allows_arm_ramp_out(decision.mode):
            self._send(False, dt_s)
        return None

    def _send(self, engage: bool, dt_s: float) -> None:
        weight = self._ramp.propose(engage, dt_s)
        blend = max(self._blend, weight) if engage else self._blend
        targets = self._targets
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
            self._targets.clear()
