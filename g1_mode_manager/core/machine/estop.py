"""The e-stop: its first packet, its registration, its verified damping sequence, and how concurrent
e-stops share one sequence.

- The first act is a DampNoReply with nothing in front of it (``shot``).
- Then it registers under the forward gate, waiting at most ``forward_wait_s`` for it: the mode becomes
  EMERGENCY, a running transition is preempted, the e-stop generation grows. No relay write and no
  robot-changing call starts after that point.
- One thread at a time runs the sequence: make the high-level service active (a DampNoReply the moment
  SelectMode answers: the released robot is limp from then until a Damp), Damp, wait until every
  robot-changing call that was in flight has landed (bounded), then verify on the robot (CheckMode names a
  service AND GetFsmId is Damp). Only that makes ``damp_confirmed`` true and the e-stop succeed; otherwise
  it re-selects and re-damps until its time budget ends. An e-stop arriving meanwhile fires its own
  DampNoReply and joins the running sequence instead of queueing behind it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

from g1_mode_manager.core.estop_policy import EstopTiming
from g1_mode_manager.core.joint_commands import DAMPING
from g1_mode_manager.core.machine.gate import ForwardGate
from g1_mode_manager.core.machine.state import MachineState
from g1_mode_manager.core.machine.user_ctrl_steps import UserCtrlSteps
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import ModePort, RobotError
from g1_mode_manager.core.preemption import RunPort
from g1_mode_manager.core.records import Outcome, Result, TransitionRecord
from g1_mode_manager.core.service_steps import StepTimeoutError, ensure_service_active
from g1_mode_manager.protocol.fsm import FsmId


@dataclass(frozen=True)
class Registration:
    source: Mode  # the mode the stop left
    gen: int  # the e-stop generation it registered as
    notes: list[str]


@dataclass(frozen=True)
class EstopRun:
    """The outcome of one finished sequence, and which registrations it covered."""

    covered: int = 0  # the e-stop generation its verification covered (success) or tried (failure)
    why: str | None = None  # None = verified damped
    notes: tuple[str, ...] = ()


def verdict(calls: RunPort) -> str:
    """'' if the robot shows damping with the service active, else what it shows."""
    return verdict_fsm(calls)[0]


def verdict_fsm(calls: RunPort) -> tuple[str, int | None]:
    """``verdict`` and the fsm GetFsmId showed (None: not asked, the service being released)."""
    name = calls.check_mode()
    if not name:
        return "robot released (CheckMode names no service): not damped", None
    fsm_id = calls.get_fsm_id()
    if fsm_id != FsmId.DAMP:
        return f"robot not damping: GetFsmId says {fsm_id}", fsm_id
    return "", fsm_id


class Estop:
    """Enters EMERGENCY and damps the robot; every outcome ends in EMERGENCY."""

    def __init__(self, state: MachineState, gate: ForwardGate, port: ModePort, timing: EstopTiming, *,
                 poll_interval_s: float, sleep: Callable[[float], None]) -> None:
        self._state = state
        self._gate = gate
        self._port = port
        self._timing = timing
        self._poll_interval_s = poll_interval_s
        self._sleep = sleep
        self._cond = threading.Condition(threading.Lock())  # the one runner and the e-stops waiting for it
        # guarded by _cond
        self._running = False
        self._last = EstopRun()
        #: The user_ctrl path's steps (None on the release path): PASSIVE before the Damp while the robot may be
        #: under user control, where SetFsmId does nothing and only rt/user_lowcmd reaches the joints.
        self.user_ctrl: UserCtrlSteps | None = None

    def shot(self) -> list[str]:
        """The first packet alone: a DampNoReply if the robot is connected (a plain read in front of it);
        returns why it failed, if it did. While the robot may be under user control a damping frame on
        rt/user_lowcmd goes first: there only that reaches the joints (SetFsmId answers and does nothing)."""
        if not self._state.connected:
            return []
        user_ctrl = self.user_ctrl
        if user_ctrl is not None and user_ctrl.link.live:
            notes = self.fire_user_damping(user_ctrl)
            return notes + self.fire_damp_no_reply()
        return self.fire_damp_no_reply()

    @staticmethod
    def fire_user_damping(user_ctrl: UserCtrlSteps) -> list[str]:
        user_ctrl.link.filler = DAMPING  # the relay repeats it until the robot is seen out of user control
        try:
            user_ctrl.port.write_user_lowcmd(DAMPING)
        except Exception as exc:
            return [f"damping frame on rt/user_lowcmd failed: {exc}"]
        return []

    def register(self, target: Mode, *, faults: tuple[str, ...] = (),
                 allowed: Callable[[Mode], bool] | None = None) -> Registration | None:
        """Enter ``target`` (EMERGENCY, or FAULT for a protective stop) under the forward gate, waiting at most
        ``forward_wait_s`` for it: a running transition is preempted, holds end, the e-stop generation grows,
        nothing is claimed damped until the robot shows it again. None if ``allowed`` refused the mode."""
        state = self._state
        notes: list[str] = []
        registered = self._gate.lock.acquire(timeout=self._timing.forward_wait_s)
        try:
            with state.lock:
                source, preempted = state.mode, state.inflight
                if allowed is not None and not allowed(source):
                    return None
                if preempted is not None:
                    preempted.preempted.set()
                    state.inflight = None
                state.mode = target
                state.mismatch = ""
                state.holds = ()
                if target is Mode.FAULT:
                    state.faults = faults
                state.damp_confirmed = False
                state.estop_gen += 1
                state.version += 1
                gen = state.estop_gen
        finally:
            if registered:
                self._gate.lock.release()
        if self.user_ctrl is not None:  # after the preemption above: an entry's hand-over begins before or never
            self.user_ctrl.link.stop()
        if not registered:
            notes.append("a relay held its write longer than the forward wait")
        if preempted is not None:
            notes.append(f"preempted {preempted.source.name}->{preempted.target.name}")
        if source is not target:
            state.leaving(source, target)
        state.notify()
        return Registration(source, gen, notes)

    def start_sequences(self) -> None:
        """Run the damping sequence in a thread of its own, unless one runs already (it covers this one)."""
        if self.claim_runner():
            threading.Thread(target=self.run_sequences, name="estop_sequence", daemon=True).start()

    def estop(self, *, wait: bool, fired: list[str] | None) -> Outcome:
        state = self._state
        start = state.clock()
        notes = self.shot() if fired is None else list(fired)  # the fastest shot first
        registration = self.register(Mode.EMERGENCY)
        assert registration is not None  # an e-stop registers in every mode
        source, gen = registration.source, registration.gen
        notes += registration.notes
        if not wait:
            self.start_sequences()
            message = "e-stop registered: DampNoReply sent, damping sequence running"
            return self._finish(source, start, Result.REGISTERED, message)
        run = self.run_sequences() if self.claim_runner() else self._join(gen)
        detail = "; ".join([*notes, *run.notes])
        detail = f" ({detail})" if detail else ""
        if run.why is None:
            return self._finish(source, start, Result.OK,
                                f"e-stop: robot damped (verified: service active, fsm Damp){detail}")
        message = f"e-stop incomplete: {run.why}; supervision keeps trying{detail}"
        with state.lock:
            state.last_refusal = message
            state.last_error = run.why
        return self._finish(source, start, Result.FAILED, message)

    def _finish(self, source: Mode, start: float, result: Result, message: str) -> Outcome:
        state = self._state
        record = TransitionRecord(source, Mode.EMERGENCY, result, state.clock() - start, message)
        with state.lock:
            state.history.append(record)
        state.emit(record)
        return Outcome(result is not Result.FAILED, Mode.EMERGENCY, message, record.duration_s, refused=False)

    # --- one runner ------------------------------------------------------------------------------
    def running(self) -> bool:
        with self._cond:
            return self._running

    def claim_runner(self) -> bool:
        with self._cond:
            if self._running:
                return False
            self._running = True
            return True

    def _join(self, gen: int) -> EstopRun:
        """Join the running sequence; if it ended before covering ``gen``, run one ourselves."""
        with self._cond:
            while self._running:
                self._cond.wait()
            if self._last.covered >= gen:
                return self._last
            self._running = True
        return self.run_sequences()

    def run_sequences(self) -> EstopRun:
        """As the one runner (claimed): sequences until every registered e-stop is covered or one failed."""
        try:
            while True:
                run = self._sequence()
                with self._cond:
                    self._last = run
                if run.why is not None or run.covered >= self._state.current_gen():
                    return run
        finally:
            with self._cond:
                self._running = False
                self._cond.notify_all()

    # --- the sequence ----------------------------------------------------------------------------
    def calls(self, until: float | None = None) -> RunPort:
        """The port with the e-stop's own short timeouts, never the transitions' long ones; with ``until``, no
        call outlasts it."""
        return RunPort(self._port, self._state.note_service, self._sleep,
                       call_timeout_s=self._timing.call_s, select_timeout_s=self._timing.select_s,
                       until=until, clock=self._state.clock)

    def _sequence(self) -> EstopRun:
        """Service active, Damp, calls in flight landed, verified on the robot; retried until verified or
        the time budget is spent."""
        state, timing = self._state, self._timing
        deadline = state.clock() + timing.total_s
        # the answer comes by deadline + one call timeout: every call is cut short there, a SelectMode retried
        # near the deadline included (its own timeout is seconds)
        calls = self.calls(until=deadline + timing.call_s)
        notes: list[str] = []
        covered = state.current_gen()
        while True:
            try:
                if not state.connected:
                    calls.connect()
                    state.set_connected()
                    notes += self.fire_damp_no_reply()
                if not self._gate.drain_writes(deadline):
                    notes.append("a relay write under way at the e-stop did not finish in time")
                remaining = max(timing.call_s, deadline - state.clock())
                if ensure_service_active(calls, timeout_s=min(timing.select_s, remaining),
                                         poll_interval_s=self._poll_interval_s, clock=state.clock, sleep=self._sleep,
                                         on_selected=partial(self._damp_at_select, notes)):
                    notes.append("SelectMode('ai') sent, DampNoReply at its answer")
                user_ctrl = self.user_ctrl
                if user_ctrl is not None:
                    user_ctrl.before_damp(calls, notes)
                calls.damp()
                if not self._gate.wait_calls_landed(deadline):
                    notes.append("a robot call in flight did not return in time")
                covered = state.current_gen()
                why, fsm = verdict_fsm(calls)
                if user_ctrl is not None:
                    user_ctrl.after_verdict(fsm, damped=not why)
            except (RobotError, StepTimeoutError) as exc:
                why = str(exc)
            except Exception as exc:
                why = f"unexpected {type(exc).__name__} from the robot port: {exc}"
            if not why:
                with state.lock:
                    state.damp_confirmed = True
                    state.late_landing = False
                    state.verified_at = state.clock()
                    state.next_verify = state.verified_at + timing.verify_period_s
                    state.version += 1
                state.notify()
                return EstopRun(covered, None, tuple(dict.fromkeys(notes)))
            with state.lock:
                state.damp_confirmed = False
            if state.clock() >= deadline:
                return EstopRun(covered, why, tuple(dict.fromkeys(notes)))
            notes.append(f"retrying: {why}")
            self._sleep(timing.retry_interval_s)

    def _damp_at_select(self, notes: list[str]) -> None:
        notes.extend(self.fire_damp_no_reply())

    def fire_damp_no_reply(self) -> list[str]:
        try:
            self._port.damp_no_reply()
        except Exception as exc:
            return [f"DampNoReply failed: {exc}"]
        return []
