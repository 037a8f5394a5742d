"""The mode state machine: executes the transition table against a ModePort, with e-stop priority.

Threading model:
- ``request()`` runs a transition in the caller's thread while holding the transition lock. A second
  concurrent request is refused at once ("busy: ..."), never queued.
- ``estop()`` never waits for the transition lock. Its first act is a DampNoReply with nothing in
  front of it; then it registers (mode EMERGENCY, the running transition preempted, the e-stop
  generation bumped) under the forward lock, so no relay send and no robot-changing call can start
  after it. One thread at a time runs the e-stop *sequence*; a request arriving meanwhile fires its
  own DampNoReply and joins the running sequence instead of queueing behind it.
- The sequence makes the high-level service active, damps, waits until every robot-changing call that
  was in flight when the e-stop began has returned (bounded), then verifies on the robot: CheckMode
  names a service AND GetFsmId is Damp. Only that makes ``damp_confirmed`` true and the e-stop succeed;
  otherwise it re-selects and re-damps until its time budget ends.
- ``supervise()`` (called periodically by the node) keeps EMERGENCY true on the robot: a robot seen out
  of damping (rt/sportmodestate, a periodic verify, a call that landed after the e-stop) is re-damped.
  Outside EMERGENCY it checks that the robot still matches the mode (CheckMode); a mismatch stops all
  forwarding until an operator requests a mode again.
- A short state lock guards the fields; callbacks run outside every lock, possibly from several
  threads at once. An exception from a callback is kept in ``last_error``; it never interrupts a
  transition or an e-stop.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from g1_mode_manager.core import modes
from g1_mode_manager.core.estop_policy import EstopTiming
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import ModePort, RobotError
from g1_mode_manager.core.preemption import Preempted, RunPort
from g1_mode_manager.core.records import MachineStatus, Outcome, Result, TransitionRecord
from g1_mode_manager.core.service_steps import StepTimeoutError, ensure_service_active, release_service
from g1_mode_manager.core.transitions import Step, Transition, lookup
from g1_mode_manager.protocol.fsm import FsmId

__all__ = ["EstopTiming", "MachineStatus", "ModeMachine", "Outcome", "Result", "TransitionRecord"]

_ZERO_TORQUE_NOTE = "robot is in zero torque; send stand_up/damp"
#: rt/sportmodestate read within this long after the robot was verified damped is no evidence against it
#: (the newest sample may predate the Damp: 50 Hz on the robot, read at the supervisor's 10 Hz), s.
STATE_SETTLE_S = 0.25
LeaveListener = Callable[[Mode, Mode], None]
AlarmListener = Callable[[str], None]


@dataclass
class _Inflight:
    """The transition being executed right now."""

    source: Mode
    target: Mode
    preempted: threading.Event = field(default_factory=threading.Event)


@dataclass
class _EstopRun:
    """The outcome of the last finished e-stop sequence, and which registrations it covered."""

    covered: int = 0  # the e-stop generation its verification covered (success) or tried (failure)
    why: str | None = None  # None = verified damped
    notes: tuple[str, ...] = ()


class ModeMachine:
    """Holds the control mode of the robot and changes it only through the transition table."""

    def __init__(
        self,
        port: ModePort,
        *,
        release_timeout_s: float = 5.0,
        poll_interval_s: float = 0.1,
        select_timeout_s: float = 10.0,
        estop_timing: EstopTiming | None = None,
        on_record: Callable[[TransitionRecord], None] | None = None,
        on_change: Callable[[MachineStatus], None] | None = None,
        on_alarm: AlarmListener | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        history_size: int = 100,
    ) -> None:
        self._port = port
        self._release_timeout_s = release_timeout_s
        self._poll_interval_s = poll_interval_s
        self._select_timeout_s = select_timeout_s
        self._timing = estop_timing or EstopTiming()
        self._on_record = on_record
        self._on_change = on_change
        self._on_alarm = on_alarm
        self._clock = clock
        self._sleep = sleep
        self._leave_listeners: list[LeaveListener] = []

        self._state_lock = threading.Lock()
        self._transition_lock = threading.Lock()
        self._forward_lock = threading.Lock()  # held by relays around one send; taken by the e-stop to register
        self._estop_cond = threading.Condition(threading.Lock())  # e-stop runner and its waiters
        self._calls_cond = threading.Condition(self._state_lock)  # robot-changing calls in flight

        # guarded by _state_lock
        self._mode = Mode.UNINITIALIZED
        self._inflight: _Inflight | None = None
        self._connected = False
        self._service_known = False
        self._service_active = False
        self._damp_confirmed = False
        self._last_refusal = ""
        self._last_error = ""
        self._mismatch = ""
        self._version = 0
        self._estop_gen = 0
        self._changing_calls = 0
        self._late_landing = False  # a robot-changing call returned after an e-stop began
        self._reasserts = 0
        self._next_verify = 0.0
        self._verified_at = float("-inf")
        self._next_belief = 0.0
        self._history: deque[TransitionRecord] = deque(maxlen=history_size)

        # guarded by _estop_cond
        self._estop_running = False
        self._estop_last = _EstopRun()

    # --- what the node reads -------------------------------------------------------------------
    @property
    def mode(self) -> Mode:
        with self._state_lock:
            return self._mode

    @property
    def timing(self) -> EstopTiming:
        return self._timing

    @property
    def history(self) -> tuple[TransitionRecord, ...]:
        """The most recent attempts, oldest first."""
        with self._state_lock:
            return tuple(self._history)

    def status(self) -> MachineStatus:
        with self._state_lock:
            return self._status_locked()

    def _status_locked(self) -> MachineStatus:
        inflight = self._inflight
        return MachineStatus(
            mode=self._mode,
            transition_in_progress=inflight is not None,
            transition_target=inflight.target if inflight is not None else None,
            service_known=self._service_known,
            service_active=self._service_active,
            damp_confirmed=self._damp_confirmed,
            last_refusal=self._last_refusal,
            last_error=self._last_error,
            robot_mismatch=self._mismatch,
            reasserts=self._reasserts,
            version=self._version,
        )

    def allows_cmd_vel(self) -> bool:
        return self._allows(modes.allows_cmd_vel)

    def allows_arm_commands(self) -> bool:
        return self._allows(modes.allows_arm_commands)

    def allows_loco_commands(self) -> bool:
        return self._allows(modes.allows_loco_commands)

    def allows_low_level_commands(self) -> bool:
        return self._allows(modes.allows_low_level_commands)

    def is_emergency(self) -> bool:
        return self.mode is Mode.EMERGENCY

    def _allows(self, predicate: Callable[[Mode], bool]) -> bool:
        """Commands pass only in a mode that allows them, never while a transition runs, never while
        the robot was seen not to match the mode."""
        with self._state_lock:
            return self._allows_locked(predicate)

    def _allows_locked(self, predicate: Callable[[Mode], bool]) -> bool:
        return self._inflight is None and not self._mismatch and predicate(self._mode)

    # --- what the relays and loco commands go through --------------------------------------------
    @contextmanager
    def forwarding(self, predicate: Callable[[Mode], bool]) -> Iterator[bool]:
        """Hold the forward gate around one send; yields whether it may pass now.

        While a body runs, no e-stop registers and no transition starts, so a send that was allowed
        cannot reach the robot after the mode closed it. Keep the body to the send itself.
        """
        with self._forward_lock:
            yield self._allows(predicate)

    @contextmanager
    def ramping_out(self) -> Iterator[bool]:
        """Hold the forward gate around one hand-back frame (an arm weight going down): allowed in every
        mode but EMERGENCY, also while a transition runs (leaving HIGH_LEVEL waits for the ramp-out).
        After an e-stop nothing but damping reaches the robot."""
        with self._forward_lock:
            with self._state_lock:
                ok = self._mode is not Mode.EMERGENCY
            yield ok

    @contextmanager
    def robot_call(self, allowed: Callable[[Mode], bool]) -> Iterator[bool]:
        """Around a blocking robot-changing call (a loco command): yields whether it may be sent.

        The check and the in-flight registration are atomic with the e-stop's registration, so an
        e-stop waits for the call to land before it verifies the robot; a call that returns after an
        e-stop began makes the supervision re-verify (and re-damp) at once.
        """
        with self._forward_lock, self._state_lock:
            ok = self._inflight is None and not self._mismatch and allowed(self._mode)
            gen = self._estop_gen
            if ok:
                self._changing_calls += 1
        try:
            yield ok
        finally:
            if ok:
                self._call_landed(gen)

    @contextmanager
    def _transition_call(self, preempted: threading.Event | None) -> Iterator[None]:
        """A transition's robot-changing call (SelectMode, ReleaseMode), registered as in flight."""
        with self._state_lock:
            if preempted is not None and preempted.is_set():
                raise Preempted("robot call")
            gen = self._estop_gen
            self._changing_calls += 1
        try:
            yield
        finally:
            self._call_landed(gen)

    def _call_landed(self, gen: int) -> None:
        with self._state_lock:
            self._changing_calls -= 1
            if self._estop_gen != gen:
                self._late_landing = True
            self._calls_cond.notify_all()

    def add_leave_listener(self, listener: LeaveListener) -> None:
        """``listener(source, target)`` runs in the thread that changes the mode, after the gate
        closed and before the transition's first robot call (an e-stop: right after its DampNoReply)."""
        self._leave_listeners.append(listener)

    # --- mode changes ----------------------------------------------------------------------------
    def request(self, target: Mode) -> Outcome:
        """Change to ``target`` following the transition table; EMERGENCY delegates to estop().

        A plain int (a Mode message constant) is accepted; a number that is no mode raises ValueError.
        Requesting the current mode while the robot does not match it re-runs that mode's entry.
        """
        target = Mode.from_value(int(target))
        if target is Mode.EMERGENCY:
            return self.estop()
        start = self._clock()
        if not self._transition_lock.acquire(blocking=False):
            with self._state_lock:
                source, inflight = self._mode, self._inflight
            if source is Mode.EMERGENCY:
                reason = str(lookup(source, target))
            elif inflight is not None:
                reason = f"busy: transition {inflight.source.name}->{inflight.target.name} in progress"
            else:
                reason = "busy: another mode request is being handled"
            return self._refuse(source, target, reason, start)
        try:
            with self._forward_lock, self._state_lock:
                source = self._mode
                rule = lookup(source, target)
                if source is target and self._mismatch and source is not Mode.EMERGENCY:
                    rule = lookup(Mode.IDLE, target) if target is not Mode.IDLE else _REENTER_IDLE
                inflight = None
                if isinstance(rule, Transition):
                    inflight = _Inflight(source, target)
                    self._inflight = inflight
                    self._version += 1
            if not isinstance(rule, Transition) or inflight is None:
                return self._refuse(source, target, str(rule), start)
            self._notify()
            if source is not target:
                self._leaving(source, target)
            return self._execute(rule, inflight, start)
        finally:
            self._transition_lock.release()

    def estop_shot(self) -> list[str]:
        """The e-stop's first packet alone: a DampNoReply if the robot is connected (a plain read in front
        of it, nothing else). For an endpoint that fires it from the thread that took the request and runs
        ``estop(fired=...)`` in another; returns the notes to pass on (why it failed, if it did)."""
        return self._fire_damp_no_reply() if self._connected else []

    def estop(self, *, wait: bool = True, fired: list[str] | None = None) -> Outcome:
        """Enter EMERGENCY now and damp the robot; always ends in EMERGENCY, whatever fails.

        success=True only once the robot itself was seen damped with the service active. With
        ``wait=False`` (a topic), the sequence runs in a thread of its own and the outcome only
        says the e-stop was registered. ``fired``: the caller already sent the first packet
        (``estop_shot()``; its notes), else it goes out here first.
        """
        start = self._clock()
        notes = self.estop_shot() if fired is None else list(fired)  # the fastest shot first
        registered = self._forward_lock.acquire(timeout=self._timing.forward_wait_s)
        try:
            with self._state_lock:
                source = self._mode
                preempted = self._inflight
                if preempted is not None:
                    preempted.preempted.set()
                    self._inflight = None
                self._mode = Mode.EMERGENCY
                self._mismatch = ""
                self._damp_confirmed = False  # nothing is claimed until the robot shows it again
                self._estop_gen += 1
                self._version += 1
                gen = self._estop_gen
        finally:
            if registered:
                self._forward_lock.release()
        if not registered:
            notes.append("a relay held its send longer than the forward wait")
        if preempted is not None:
            notes.append(f"preempted {preempted.source.name}->{preempted.target.name}")
        if source is not Mode.EMERGENCY:
            self._leaving(source, Mode.EMERGENCY)
        self._notify()
        if not wait:
            if self._claim_runner():
                threading.Thread(target=self._run_estops, name="estop_sequence", daemon=True).start()
            message = "e-stop registered: DampNoReply sent, damping sequence running"
            record = TransitionRecord(source, Mode.EMERGENCY, Result.REGISTERED, self._clock() - start, message)
            with self._state_lock:
                self._history.append(record)
            self._emit(record)
            return Outcome(True, Mode.EMERGENCY, message, record.duration_s, refused=False)
        run = self._run_estops() if self._claim_runner() else self._await_estop(gen)
        return self._estop_outcome(source, start, run, notes)

    def _estop_outcome(self, source: Mode, start: float, run: _EstopRun, notes: list[str]) -> Outcome:
        duration = self._clock() - start
        all_notes = [*notes, *run.notes]
        detail = f" ({'; '.join(all_notes)})" if all_notes else ""
        with self._state_lock:
            if run.why is None:
                result, message = Result.OK, f"e-stop: robot damped (verified: service active, fsm Damp){detail}"
            else:
                result = Result.FAILED
                message = f"e-stop incomplete: {run.why}; supervision keeps trying{detail}"
                self._last_refusal = message
                self._last_error = run.why
            record = TransitionRecord(source, Mode.EMERGENCY, result, duration, message)
            self._history.append(record)
        self._emit(record)
        return Outcome(result is Result.OK, Mode.EMERGENCY, message, duration, refused=False)

    # --- supervision -----------------------------------------------------------------------------
    def supervise(self, fsm_id: int | None = None, state_age_s: float | None = None) -> None:
        """One periodic look at the robot (the node calls this at ~10 Hz with rt/sportmodestate).

        EMERGENCY: re-damp a robot seen out of damping; outside it: check the robot matches the mode.
        """
        now = self._clock()
        with self._state_lock:
            mode, connected, transition = self._mode, self._connected, self._inflight is not None
        if not connected and mode is not Mode.EMERGENCY:
            return
        if mode is Mode.EMERGENCY:
            self._supervise_emergency(now, fsm_id, state_age_s)
        elif mode in (Mode.HIGH_LEVEL, Mode.LOW_LEVEL) and not transition:
            self._check_belief(now, mode)

    def _supervise_emergency(self, now: float, fsm_id: int | None, state_age_s: float | None) -> None:
        with self._estop_cond:
            if self._estop_running:
                return
        with self._state_lock:
            late, self._late_landing = self._late_landing, False
            confirmed = self._damp_confirmed
            verify_due = now >= self._next_verify
            if verify_due:
                self._next_verify = now + self._timing.verify_period_s
            # a sample read just after a verification may have been sent before the Damp took effect
            settled = now - self._verified_at > STATE_SETTLE_S
        fresh = (fsm_id is not None and state_age_s is not None and state_age_s <= self._timing.state_fresh_s
                 and settled)
        why = ""
        if late:
            why = "a robot call landed after the e-stop began"
        elif fresh and fsm_id != FsmId.DAMP:
            why = f"robot left damping: rt/sportmodestate says fsm {fsm_id}"
        elif not confirmed:
            why = "the last e-stop sequence did not verify the robot damped"
        elif verify_due:
            why = self._verify_now()
        if not why:
            return
        if not self._claim_runner():
            return
        with self._state_lock:
            self._reasserts += 1
            self._damp_confirmed = False
            self._version += 1
        self._alarm(f"EMERGENCY re-asserted: {why}")
        self._fire_damp_no_reply()
        run = self._run_estops()
        if run.why is not None:
            self._alarm(f"EMERGENCY re-assert incomplete: {run.why}")

    def _verify_now(self) -> str:
        """'' if CheckMode names a service and GetFsmId is Damp, else why not."""
        calls = self._estop_calls()
        try:
            return self._verdict(calls)
        except (RobotError, StepTimeoutError) as exc:
            return f"verification failed: {exc}"
        except Exception as exc:
            return f"verification failed: unexpected {type(exc).__name__}: {exc}"

    def _check_belief(self, now: float, mode: Mode) -> None:
        with self._state_lock:
            if now < self._next_belief or self._mismatch:
                return
            self._next_belief = now + self._timing.belief_period_s
            version = self._version
        try:
            name = self._port.check_mode(timeout_s=self._timing.call_s)
        except Exception:  # a lost answer is link health's business, not a mismatch
            return
        expected_active = mode is Mode.HIGH_LEVEL
        if bool(name) == expected_active:
            return
        what = f"service {name!r} active" if name else "the high-level service released"
        self.report_mismatch(f"robot does not match {mode.name}: CheckMode says {what}", version)

    def report_mismatch(self, reason: str, version: int | None = None) -> None:
        """The robot no longer matches the mode (another program, a reboot): stop forwarding until an
        operator requests a mode again. Ignored in EMERGENCY (supervision handles it there), and if
        the state changed since ``version`` (the evidence is then stale)."""
        with self._forward_lock, self._state_lock:
            if self._mode in (Mode.EMERGENCY, Mode.UNINITIALIZED) or self._inflight is not None or self._mismatch:
                return
            if version is not None and version != self._version:
                return
            self._mismatch = reason
            self._service_known = False
            self._last_error = reason
            self._version += 1
        self._alarm(f"{reason}; forwarding stopped until a mode is requested again")
        self._notify()

    # --- internals: transitions ------------------------------------------------------------------
    def _execute(self, rule: Transition, inflight: _Inflight, start: float) -> Outcome:
        calls = RunPort(self._port, self._note_service, self._sleep, inflight.preempted,
                        changing_call=self._transition_call)
        error = ""
        selected = False
        try:
            selected = self._run_steps(rule, calls)
        except Preempted:
            pass
        except (RobotError, StepTimeoutError) as exc:
            error = str(exc)
        except Exception as exc:  # a port must raise RobotError; anything else is reported, not raised
            error = f"unexpected {type(exc).__name__} from the robot port: {exc}"
        duration = self._clock() - start
        source, target = inflight.source.name, inflight.target.name
        with self._state_lock:
            if self._inflight is inflight:
                self._inflight = None
            if inflight.preempted.is_set():  # the e-stop owns the mode now; commit nothing
                result, message = Result.PREEMPTED, f"{source}->{target} preempted by e-stop"
            elif error:
                result, message = Result.FAILED, f"{source}->{target} failed, staying in {source}: {error}"
                self._last_refusal = message
                self._last_error = error
            else:
                self._mode = inflight.target
                self._mismatch = ""
                self._next_belief = self._clock() + self._timing.belief_period_s
                result, message = Result.OK, f"{source}->{target}: {rule.description}"
                if selected or (rule.source is Mode.LOW_LEVEL and rule.target is Mode.HIGH_LEVEL):
                    message += f"; {_ZERO_TORQUE_NOTE}"
            self._version += 1
            mode = self._mode
            record = TransitionRecord(inflight.source, inflight.target, result, duration, message)
            self._history.append(record)
        self._emit(record)
        return Outcome(result is Result.OK, mode, message, duration, refused=False)

    def _run_steps(self, rule: Transition, calls: RunPort) -> bool:
        """Run the rule's steps; True if SelectMode was sent (the robot is then limp)."""
        selected = False
        for step in rule.steps:
            match step:
                case Step.CONNECT:
                    calls.connect()
                    self._set_connected()
                case Step.ENSURE_SERVICE_ACTIVE:
                    selected = ensure_service_active(
                        calls,
                        timeout_s=self._select_timeout_s,
                        poll_interval_s=self._poll_interval_s,
                        clock=self._clock,
                        sleep=calls.sleep,
                    )
                case Step.RELEASE_SERVICE:
                    release_service(
                        calls,
                        timeout_s=self._release_timeout_s,
                        poll_interval_s=self._poll_interval_s,
                        clock=self._clock,
                        sleep=calls.sleep,
                    )
                case Step.ESTOP:
                    raise AssertionError("request() hands EMERGENCY to estop()")
        return selected

    def _leaving(self, source: Mode, target: Mode) -> None:
        for listener in self._leave_listeners:
            try:
                listener(source, target)
            except Exception as exc:
                self._note_callback_error("leave listener", exc)

    # --- internals: the e-stop sequence ------------------------------------------------------------
    def _claim_runner(self) -> bool:
        with self._estop_cond:
            if self._estop_running:
                return False
            self._estop_running = True
            return True

    def _await_estop(self, gen: int) -> _EstopRun:
        """Join the running sequence; if it ended before covering ``gen``, run one ourselves."""
        with self._estop_cond:
            while self._estop_running:
                self._estop_cond.wait()
            last = self._estop_last
            if last.covered >= gen:
                return last
            self._estop_running = True
        return self._run_estops()

    def _run_estops(self) -> _EstopRun:
        """As the one runner: sequences until every registered e-stop is covered (or one failed)."""
        try:
            while True:
                run = self._estop_sequence()
                with self._estop_cond:
                    self._estop_last = run
                if run.why is not None or run.covered >= self._current_gen():
                    return run
        finally:
            with self._estop_cond:
                self._estop_running = False
                self._estop_cond.notify_all()

    def _drain_sends(self, deadline: float) -> bool:
        """Wait until a relay send that was under way when the e-stop registered has finished.

        Registration waits only ``forward_wait_s`` for the forward gate (the e-stop is never held up by a
        relay); a send allowed before it may still be on its way, e.g. an arm frame whose thread was
        descheduled. No new send passes after registration, so once the gate is free only damping reaches
        the robot, and the sequence's Damp lands after that last send (seen in the chaos suite under load:
        an arm_sdk frame received after the sequence's Damp)."""
        if not self._forward_lock.acquire(timeout=max(0.0, deadline - self._clock())):
            return False
        self._forward_lock.release()
        return True

    def _current_gen(self) -> int:
        with self._state_lock:
            return self._estop_gen

    def _estop_calls(self) -> RunPort:
        return RunPort(self._port, self._note_service, self._sleep,
                       call_timeout_s=self._timing.call_s, select_timeout_s=self._timing.select_s)

    def _estop_sequence(self) -> _EstopRun:
        """Make the service active, Damp, wait for calls in flight, verify on the robot; retry until
        verified or the time budget is spent."""
        timing = self._timing
        deadline = self._clock() + timing.total_s
        calls = self._estop_calls()
        notes: list[str] = []
        why = "no attempt"
        covered = self._current_gen()
        while True:
            try:
                if not self._connected:
                    calls.connect()
                    self._set_connected()
                    notes += self._fire_damp_no_reply()
                if not self._drain_sends(deadline):
                    notes.append("a relay send under way at the e-stop did not finish in time")
                remaining = max(timing.call_s, deadline - self._clock())
                if ensure_service_active(calls, timeout_s=min(timing.select_s, remaining),
                                         poll_interval_s=self._poll_interval_s, clock=self._clock, sleep=self._sleep):
                    notes.append("SelectMode('ai') sent")
                calls.damp()
                if not self._wait_calls_landed(deadline):
                    notes.append("a robot call in flight did not return in time")
                covered = self._current_gen()
                why = self._verdict(calls)
            except (RobotError, StepTimeoutError) as exc:
                why = str(exc)
            except Exception as exc:
                why = f"unexpected {type(exc).__name__} from the robot port: {exc}"
            if not why:
                with self._state_lock:
                    self._damp_confirmed = True
                    self._late_landing = False
                    self._verified_at = self._clock()
                    self._next_verify = self._verified_at + timing.verify_period_s
                    self._version += 1
                self._notify()
                return _EstopRun(covered, None, tuple(dict.fromkeys(notes)))
            with self._state_lock:
                self._damp_confirmed = False
            if self._clock() >= deadline:
                return _EstopRun(covered, why, tuple(dict.fromkeys(notes)))
            notes.append(f"retrying: {why}")
            self._sleep(timing.retry_interval_s)

    def _verdict(self, calls: RunPort) -> str:
        """'' if the robot shows damping with the service active, else what it shows."""
        name = calls.check_mode()
        if not name:
            return "robot released (CheckMode names no service): not damped"
        fsm_id = calls.get_fsm_id()
        if fsm_id != FsmId.DAMP:
            return f"robot not damping: GetFsmId says {fsm_id}"
        return ""

    def _wait_calls_landed(self, deadline: float) -> bool:
        """Wait until no robot-changing call is in flight (each ends by its reply or its timeout)."""
        with self._state_lock:
            while self._changing_calls > 0:
                left = deadline - self._clock()
                if left <= 0:
                    return False
                self._calls_cond.wait(min(left, 0.05))
            return True

    def _fire_damp_no_reply(self) -> list[str]:
        try:
            self._port.damp_no_reply()
        except Exception as exc:
            return [f"DampNoReply failed: {exc}"]
        return []

    def _note_service(self, known: bool, active: bool, preempted: threading.Event | None) -> None:
        with self._state_lock:
            if preempted is not None and preempted.is_set():
                return  # a preempted run's late answers must not overwrite the e-stop's knowledge
            self._service_known = known
            self._service_active = known and active

    def _set_connected(self) -> None:
        with self._state_lock:
            self._connected = True

    def _refuse(self, source: Mode, target: Mode, reason: str, start: float) -> Outcome:
        duration = self._clock() - start
        record = TransitionRecord(source, target, Result.REFUSED, duration, reason)
        with self._state_lock:
            self._last_refusal = reason
            self._history.append(record)
            self._version += 1
            mode = self._mode
        self._emit(record)
        return Outcome(False, mode, reason, duration, refused=True)

    def _emit(self, record: TransitionRecord) -> None:
        if self._on_record is not None:
            try:
                self._on_record(record)
            except Exception as exc:
                self._note_callback_error("on_record", exc)
        self._notify()

    def _notify(self) -> None:
        if self._on_change is None:
            return
        try:
            self._on_change(self.status())
        except Exception as exc:
            self._note_callback_error("on_change", exc)

    def _alarm(self, text: str) -> None:
        with self._state_lock:
            self._last_error = text
            self._version += 1
        if self._on_alarm is not None:
            try:
                self._on_alarm(text)
            except Exception as exc:
                self._note_callback_error("on_alarm", exc)
        self._notify()

    def _note_callback_error(self, name: str, exc: Exception) -> None:
        with self._state_lock:
            self._last_error = f"{name} callback raised {type(exc).__name__}: {exc}"


#: Re-entering IDLE after a mismatch: nothing to do on the robot, forwarding stays off.
_REENTER_IDLE = Transition(Mode.IDLE, Mode.IDLE, (), "re-entered: nothing is forwarded")
