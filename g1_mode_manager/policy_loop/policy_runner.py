"""A controller (a learned policy) run inside the node's own loop: its lifecycle verbs, and each tick from the
newest state sample to a frame handed to the lowcmd relay.

What reaches the robot is decided where it is for ``~/lowcmd``: every target passes the same frame check
(core/controller/targets.py) and the same forward gate, link, dead-man and silence rules (``submit_frame``), so an
e-stop, a FAULT, a body check's hold or L2+B cut the policy off exactly as they cut off a user's controller. A
fault inside the loop (an exception, a non-finite or out-of-range target, overruns, a stale state sample) stops
the policy's frames and ends the stream at once: on the user_ctrl path the relay holds the pose and hands the
robot back (WALKRUN when upright -> IDLE, PASSIVE -> FAULT when not), on the release path it damps.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from g1_mode_manager.core.body.motion_allowance import MotionRecord
from g1_mode_manager.core.controller.blend import Blend
from g1_mode_manager.core.controller.clamps import TargetClamp
from g1_mode_manager.core.controller.interface import Command, Controller, ControllerError, JointTargets, RobotState
from g1_mode_manager.core.controller.phases import IN_LOW_LEVEL, SENDING, TICKING, Phase, Verb, next_phase
from g1_mode_manager.core.controller.targets import frame_of
from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.joint_commands import JointFrame
from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotPort, StateSample
from g1_mode_manager.core.velocity import ZERO, VelocityLimits
from g1_mode_manager.policy_loop.tick_stats import TickStats
from g1_mode_manager.protocol.motors import JOINT_NAMES
from g1_mode_manager.relay.lowcmd import LowCmdRelay
from g1_mode_manager.relay.velocity_source import VelocitySource


class DisengageTo(StrEnum):
    WALKRUN = "walkrun"  # LOW_LEVEL -> HIGH_LEVEL: the robot's own controller takes it back standing
    HOLD = "hold"  # the last pose held in LOW_LEVEL until the operator decides


@dataclass(frozen=True)
class PolicyLimits:
    """The loop's bounds (node/settings.py holds their defaults and says why)."""

    #: short: the policy runs during the blend and pushes against a robot held back from its targets (at 2 s the
    #: walker's ankle target grew past its range, docs/policies.md); the shadow check bounds the step it softens
    blend_s: float = 0.5
    engage_max_error_rad: float = 0.5
    state_timeout_s: float = 0.05
    overrun_s: float = 0.02
    max_overruns: int = 3
    #: a policy's target may stay past its joint's range + margin (clamped there) this long, s; the dances' longest
    #: run is 0.1 s (docs/policies.md)
    clamp_max_s: float = 0.5
    disengage: DisengageTo = DisengageTo.WALKRUN


@dataclass
class Shadow:
    """The controller's latest targets beside the measured joints of the same sample (for ~/policy/targets)."""

    targets: np.ndarray = field(default_factory=lambda: np.zeros(len(JOINT_NAMES)))
    measured: np.ndarray = field(default_factory=lambda: np.zeros(len(JOINT_NAMES)))
    at: float = float("-inf")
    #: RMS over the joints of measured - the motion's reference, rad (None: the policy follows no reference)
    tracking_error_rad: float | None = None


class PolicyRunner:
    def __init__(self, port: RobotPort, machine: ModeMachine, lowcmd: LowCmdRelay, events: RelayEvents, *,
                 loader: Callable[[str], Controller], limits: PolicyLimits, velocity_limits: VelocityLimits,
                 cmd_vel_timeout_s: float, hold_gains: tuple[float, float], motion: MotionRecord | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        """``motion``: where the ticks of a tracking policy note what its motion asks (the body checks read it)."""
        self._port = port
        self._machine = machine
        self._lowcmd = lowcmd
        self._events = events
        self._loader = loader
        self.limits = limits
        self._clock = clock
        self._hold_gains = hold_gains
        self._motion = motion
        self.velocity = VelocitySource(Driver.TELEOP, "cmd_vel", velocity_limits, cmd_vel_timeout_s, 0.25, clock)
        self._lock = threading.Lock()  # the phase, the controller, the blend, the hold frame
        self._verb_lock = threading.Lock()  # one lifecycle verb at a time (engage waits on the robot)
        self.phase = Phase.UNLOADED
        self.controller: Controller | None = None
        self._blend: Blend | None = None
        self._blend_at = 0.0
        self._ready: JointTargets | None = None  # a tracking policy's first frame, blended to before it starts
        self._hold: JointFrame | None = None
        self.shadow = Shadow()
        self.stats = TickStats()
        self.clamp = TargetClamp(limits.clamp_max_s)
        self.last_fault = ""
        self.wake: Callable[[], None] = lambda: None  # the loop's worker looks now (set by whoever builds it)
        self.on_phase_change: Callable[[], None] = lambda: None  # e.g. publish the status (not under the lock)

    # --- what the node asks -------------------------------------------------------------------------
    def ticking(self) -> bool:
        return self.phase in TICKING

    def takes_velocity(self) -> bool:
        """cmd_vel goes to the policy (not to LocoClient) while it drives the robot."""
        return self.phase in SENDING

    def owns_low_level(self) -> bool:
        """While the policy is in LOW_LEVEL, ~/lowcmd from elsewhere is refused (two writers would interleave)."""
        return self.phase in IN_LOW_LEVEL

    def period_s(self) -> float:
        controller = self.controller
        return 1.0 / controller.rate_hz if controller is not None else 0.02

    def offer_velocity(self, vx: float, vy: float, wz: float) -> None:
        result = self.velocity.sanitize(vx, vy, wz)
        if result.rejected or result.clamped:
            self._events.count("policy_cmd_vel_limited")
            self._events.log("warn", "policy_cmd_vel", f"cmd_vel to the policy: {result.reason}")
        with self._lock:
            self.velocity.take(result.velocity)

    # --- lifecycle verbs (service threads) ----------------------------------------------------------
    def load(self, policy: str) -> tuple[bool, str]:
        with self._verb_lock:
            if (why := _refusal(Verb.LOAD, self.phase)):
                return False, why
            try:
                controller = self._loader(policy)
            except ControllerError as exc:
                return False, f"policy {policy!r} refused: {exc}"
            with self._lock:
                self.controller, self.phase, self.last_fault = controller, Phase.LOADED, ""
            self._events.log("info", "policy_load", f"policy {controller.name} loaded and checked, nothing sent; "
                             f"action scale: {controller.action_scale_rule}")
            return True, (f"policy {controller.name} loaded at {controller.rate_hz:g} Hz (action scale: "
                          f"{controller.action_scale_rule}); nothing sent to the robot")

    def unload(self) -> tuple[bool, str]:
        with self._verb_lock:
            if (why := _refusal(Verb.UNLOAD, self.phase)):
                return False, why
            with self._lock:
                self.controller, self.phase = None, Phase.UNLOADED
            return True, "policy unloaded"

    def start_shadow(self) -> tuple[bool, str]:
        with self._verb_lock:
            if (why := _refusal(Verb.SHADOW, self.phase)):
                return False, why
            assert self.controller is not None
            with self._lock:
                self.controller.activate(self._state_or_none())
                self.stats = TickStats()
                self.clamp.reset()
                self.shadow = Shadow()
                self.phase = Phase.SHADOW
            self.wake()
            return True, (f"policy {self.controller.name} runs on the live state; its targets go to ~/policy/targets, "
                          "nothing to the robot")

    def engage(self) -> tuple[bool, str]:
        """LOW_LEVEL by the configured path, then a blend from the measured pose to the policy's targets."""
        with self._verb_lock:
            if (why := _refusal(Verb.ENGAGE, self.phase)):
                return False, why
            if (why := self._shadow_disagrees()) is not None:
                return False, f"engage refused: {why}; nothing sent"
            assert self.controller is not None
            try:
                ready = self.controller.ready()
                if ready is not None:
                    frame_of(ready)
            except ControllerError as exc:
                return False, f"engage refused: the policy's first frame: {exc}; nothing sent"
            with self._lock:
                self.phase = Phase.ENGAGING
            outcome = self._machine.request(Mode.LOW_LEVEL)
            with self._lock:
                if not outcome.success or self.phase is not Phase.ENGAGING:
                    if self.phase is Phase.ENGAGING:
                        self.phase = Phase.LOADED
                    return False, f"engage failed: {outcome.message}; the policy is {self.phase.value}"
                state = self._state_or_none()
                if state is None:
                    self.phase = Phase.LOADED
                    fail = "no fresh state sample after the entry"
                else:
                    assert self.controller is not None
                    self._ready = self.controller.ready()
                    if self._ready is None:  # else activated at the end of the blend, on its first frame
                        self.controller.activate(state)
                    self._blend, self._blend_at = Blend(state.q, self.limits.blend_s), self._clock()
                    self.velocity.forget()
                    self.velocity.limiter.reset()
                    self.phase = Phase.BLENDING
                    fail = ""
            if fail:
                self._lowcmd.end_stream()
                return False, f"engage failed: {fail}; the robot is handed back"
            self.wake()
            self._events.log("info", "policy_engage", f"policy engaged: blending over {self.limits.blend_s:g} s")
            return True, f"LOW_LEVEL entered; blending from the measured pose over {self.limits.blend_s:g} s"

    def disengage(self, to: DisengageTo | None = None) -> tuple[bool, str]:
        """Back to the robot's own controller standing (walkrun), or the last pose held in LOW_LEVEL (hold)."""
        to = self.limits.disengage if to is None else to
        with self._verb_lock:
            phase = self.phase
            if phase is Phase.SHADOW:
                with self._lock:
                    self.phase = Phase.LOADED
                    self._deactivate()
                return True, "shadow stopped; the policy is loaded"
            if to is DisengageTo.HOLD and phase is not Phase.HOLDING:
                if (why := _refusal(Verb.HOLD, phase)):
                    return False, why
                hold = self._hold_here()
                if hold is None:
                    return False, "no fresh state sample to hold"
                with self._lock:
                    self._hold, self.phase = hold, Phase.HOLDING
                return True, "the policy stopped; the robot holds its pose in LOW_LEVEL (disengage again to hand back)"
            if (why := _refusal(Verb.DISENGAGE, phase)):
                return False, why
            with self._lock:
                self.phase = Phase.DISENGAGING
            outcome = self._machine.request(Mode.HIGH_LEVEL)
            with self._lock:
                if self.phase is Phase.DISENGAGING:  # the machine refused and LOW_LEVEL stands: go on as before
                    self.phase = phase
            return outcome.success, outcome.message

    # --- the machine's leave listener -----------------------------------------------------------------
    def on_leave(self, source: Mode, target: Mode) -> None:
        if source is not Mode.LOW_LEVEL or self.phase not in IN_LOW_LEVEL:
            return
        with self._lock:
            was, self.phase = self.phase, Phase.LOADED
            self._deactivate()
        self._events.log("info", "policy_left", f"LOW_LEVEL left for {target.name} while the policy was "
                         f"{was.value}: the policy stopped (loaded)")
        self.on_phase_change()

    # --- the loop --------------------------------------------------------------------------------------
    def tick(self, dt_s: float) -> None:
        """One tick. The policy steps outside the lock: a slow inference never holds up a verb or the machine's
        leave listener (a FAULT's transition waits for its listeners); what it proposed is used only if the phase
        did not change meanwhile."""
        started = time.perf_counter()
        with self._lock:
            phase, controller = self.phase, self.controller
            if phase not in TICKING or controller is None:
                return
            sample = self._port.state_sample()
            stale = _stale(sample, self.limits.state_timeout_s)
            if stale:
                if phase in SENDING:
                    self._fault(f"state sample {stale}")
                else:
                    self.stats.skipped += 1
                return
            assert sample is not None
            state = _state_of(sample)
            # a hold, and the blend to a tracking policy's first frame, ask nothing of the policy
            asks = phase is not Phase.HOLDING and not (phase is Phase.BLENDING and self._ready is not None)
            command = self._command(dt_s) if asks else None
        try:
            targets = controller.step(state, command) if command is not None else None
        except Exception as exc:  # a policy's bug is a fault of the loop, never of the node
            with self._lock:
                if self.phase is phase:
                    self._fault(f"the policy failed: {type(exc).__name__}: {exc}")
            return
        inferred = time.perf_counter()
        with self._lock:
            if self.phase is not phase or self.controller is not controller:
                return  # left LOW_LEVEL, faulted or disengaged while the policy stepped
            try:
                frame = None if phase not in SENDING else self._frame(phase, targets, state)
            except ControllerError as exc:
                self._fault(str(exc))
                return
            shown = targets.q if targets is not None else np.asarray(frame.q if frame else state.q)
            reference = controller.reference() if phase is Phase.RUNNING else None
            tracking = None if reference is None else float(np.sqrt(np.mean((state.q - reference) ** 2)))
            speeds = controller.reference_speeds() if targets is not None and self._motion is not None else None
            if speeds is not None:
                self._motion.note(*speeds)  # type: ignore[union-attr]
            self.shadow = Shadow(shown.copy(), state.q.copy(), self._clock(), tracking)
        if frame is not None:
            why = self._lowcmd.submit_frame(frame)
            if why is None:
                self.stats.frame_written(time.monotonic(), sample.published_s, 1.0 / controller.rate_hz)
            else:
                self._events.count("policy_frames_not_sent")
                self.stats.frame_not_written()
        ended = time.perf_counter()
        if self.stats.add(dt_s, inferred - started, ended - started, self.limits.overrun_s) >= self.limits.max_overruns:
            with self._lock:
                if self.phase in TICKING:
                    self._fault(f"{self.stats.overruns_in_a_row} ticks in a row over {self.limits.overrun_s * 1e3:g} ms")

    def _frame(self, phase: Phase, targets: JointTargets | None, state: RobotState) -> JointFrame:
        """Under the lock: the frame of a sending tick (the hold, the blend, or the policy's targets)."""
        if phase is Phase.HOLDING and self._hold is not None:
            return self._hold
        if phase is Phase.BLENDING and self._blend is not None:
            elapsed = self._clock() - self._blend_at
            toward = self._ready if self._ready is not None else self._clamped(targets)
            blended = self._blend.apply(toward, elapsed)
            if self._blend.weight(elapsed) >= 1.0:
                self.phase = Phase.RUNNING
                if self._ready is not None and self.controller is not None:  # at the first frame: the clip starts
                    self.controller.activate(state)
                    self._ready = None
            return frame_of(blended)
        return frame_of(self._clamped(targets))

    def _clamped(self, targets: JointTargets | None) -> JointTargets:
        """Under the lock: the policy's targets clamped into reach, each new clamp logged (raises ControllerError
        once one is held too long)."""
        assert targets is not None
        clamped = self.clamp.apply(targets, self._clock())
        for i in self.clamp.started:
            self._events.count("policy_clamps")
            self._events.log("warn", f"policy_clamp_{i}", f"policy target of {JOINT_NAMES[i]} clamped: "
                             f"{targets.q[i]:.3f} rad -> {clamped.q[i]:.3f} (its range + margin)")
        return clamped

    def blend_progress(self) -> float:
        if self.phase is Phase.BLENDING and self._blend is not None:
            return self._blend.weight(self._clock() - self._blend_at)
        return 1.0 if self.phase in (Phase.RUNNING, Phase.HOLDING, Phase.DISENGAGING) else 0.0

    def _command(self, dt_s: float) -> Command:
        source = self.velocity
        target = ZERO if source.watchdog.expired() else source.target
        v = source.limiter.step(target, dt_s)
        return Command(v.vx, v.vy, v.wz)

    def _fault(self, why: str) -> None:
        """Under the lock: the policy stops here; the relay reacts as to silence, now."""
        was = self.phase
        self.phase = Phase.LOADED
        self.last_fault = why
        self._deactivate()
        self._events.count("policy_faults")
        self._events.log("error", "policy_fault", f"policy fault while {was.value}: {why}"
                         + ("; the robot is held and handed back" if was in SENDING else "; nothing was sent"))
        if was in SENDING:
            self._lowcmd.end_stream()
        self.on_phase_change()  # a wake only: nothing that waits for this lock

    def _deactivate(self) -> None:
        if self.controller is not None:
            self.controller.deactivate()
        self._blend = self._hold = self._ready = None
        self.velocity.forget()

    def _state_or_none(self) -> RobotState | None:
        sample = self._port.state_sample()
        return None if _stale(sample, self.limits.state_timeout_s) else _state_of(sample)  # type: ignore[arg-type]

    def _shadow_disagrees(self) -> str | None:
        """The shadow's latest targets must be fresh and near the measured pose of their sample; a tracking
        policy's are not compared (the engage blends the robot to its first frame before it starts)."""
        shadow = self.shadow
        if self._clock() - shadow.at > max(0.1, 5 * self.period_s()):
            return "the shadow has no fresh targets (is rt/lowstate received?)"
        if self.controller is not None and self.controller.ready() is not None:
            return None
        error = np.abs(shadow.targets - shadow.measured)
        worst = int(np.argmax(error))
        if error[worst] > self.limits.engage_max_error_rad:
            return (f"the policy's target for {JOINT_NAMES[worst]} is {error[worst]:.2f} rad from the measured pose "
                    f"(policy_engage_max_error_rad {self.limits.engage_max_error_rad:g})")
        return None

    def _hold_here(self) -> JointFrame | None:
        state = self._state_or_none()
        if state is None:
            return None
        kp, kd = self._hold_gains
        n = len(JOINT_NAMES)
        return frame_of(JointTargets(state.q, np.zeros(n), np.zeros(n), np.full(n, kp), np.full(n, kd)))


def _refusal(verb: Verb, phase: Phase) -> str | None:
    """Why ``verb`` is refused in ``phase`` (None: it applies)."""
    target = next_phase(verb, phase)
    return None if isinstance(target, Phase) else target


def _stale(sample: StateSample | None, timeout_s: float) -> str:
    """Why a sample cannot drive a policy tick ("" if it can)."""
    if sample is None:
        return "missing"
    if sample.age_s > timeout_s:
        return f"{sample.age_s * 1e3:.0f} ms old (> {timeout_s * 1e3:g} ms)"
    if len(sample.fields.q) != len(JOINT_NAMES):
        return "without joint positions"
    return ""


def _state_of(sample: StateSample) -> RobotState:
    f = sample.fields
    return RobotState.of(f.q, f.dq, f.quaternion, f.gyroscope, sample.age_s)
