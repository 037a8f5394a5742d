"""The mode state machine: executes the transition table against a ModePort, with e-stop priority.

Threading model:
- ``request()`` runs a transition in the caller's thread while holding the transition lock. A second
  concurrent request is refused at once ("busy: ..."), never queued.
- ``estop()`` never waits for the transition lock. It marks the running transition preempted,
  switches the mode to EMERGENCY and fires DampNoReply at once, then runs its own sequence under
  the e-stop lock. A concurrent second ``estop()`` fires its own DampNoReply, waits for the first
  sequence to end, then runs the whole sequence again (a repeated e-stop is a retry).
- A short state lock guards the fields; callbacks (``on_record``, ``on_change``) run outside every
  lock, possibly from several threads at once, each with the snapshot taken when it fires. An
  exception from a callback is kept in ``last_error``; it never interrupts a transition or an e-stop.

Knowledge of the high-level service comes only from CheckMode answers; SelectMode, ReleaseMode and a
failed Damp make it unknown. An e-stop damps directly only from HIGH_LEVEL with the service known to
be active and no transition running; everywhere else it first makes the service active (Damp is not
available in debug mode). If that direct Damp fails, the same e-stop falls back to the full sequence.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from g1_mode_manager.core import modes
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import ModePort, RobotError
from g1_mode_manager.core.preemption import Preempted, RunPort
from g1_mode_manager.core.records import MachineStatus, Outcome, Result, TransitionRecord
from g1_mode_manager.core.service_steps import StepTimeoutError, ensure_service_active, release_service
from g1_mode_manager.core.transitions import Step, Transition, lookup

__all__ = ["MachineStatus", "ModeMachine", "Outcome", "Result", "TransitionRecord"]

_ZERO_TORQUE_NOTE = "robot is in zero torque; send stand_up/damp"


@dataclass
class _Inflight:
    """The transition being executed right now."""

    source: Mode
    target: Mode
    preempted: threading.Event = field(default_factory=threading.Event)


class ModeMachine:
    """Holds the control mode of the robot and changes it only through the transition table."""

    def __init__(
        self,
        port: ModePort,
        *,
        release_timeout_s: float = 5.0,
        poll_interval_s: float = 0.1,
        select_timeout_s: float = 10.0,
        on_record: Callable[[TransitionRecord], None] | None = None,
        on_change: Callable[[MachineStatus], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        history_size: int = 100,
    ) -> None:
        self._port = port
        self._release_timeout_s = release_timeout_s
        self._poll_interval_s = poll_interval_s
        self._select_timeout_s = select_timeout_s
        self._on_record = on_record
        self._on_change = on_change
        self._clock = clock
        self._sleep = sleep

        self._state_lock = threading.Lock()
        self._transition_lock = threading.Lock()
        self._estop_lock = threading.Lock()

        # guarded by _state_lock
        self._mode = Mode.UNINITIALIZED
        self._inflight: _Inflight | None = None
        self._connected = False
        self._service_known = False
        self._service_active = False
        self._damp_confirmed = False
        self._last_refusal = ""
        self._last_error = ""
        self._history: deque[TransitionRecord] = deque(maxlen=history_size)

    # --- what the node reads -------------------------------------------------------------------
    @property
    def mode(self) -> Mode:
        with self._state_lock:
            return self._mode

    @property
    def history(self) -> tuple[TransitionRecord, ...]:
        """The most recent attempts, oldest first."""
        with self._state_lock:
            return tuple(self._history)

    def status(self) -> MachineStatus:
        with self._state_lock:
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
        """Commands pass only in a mode that allows them and never while a transition runs."""
        with self._state_lock:
            return self._inflight is None and predicate(self._mode)

    # --- mode changes ----------------------------------------------------------------------------
    def request(self, target: Mode) -> Outcome:
        """Change to ``target`` following the transition table; EMERGENCY delegates to estop().

        A plain int (a Mode message constant) is accepted; a number that is no mode raises ValueError.
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
            with self._state_lock:
                source = self._mode
                rule = lookup(source, target)
                inflight = None
                if isinstance(rule, Transition):
                    inflight = _Inflight(source, target)
                    self._inflight = inflight
            if not isinstance(rule, Transition) or inflight is None:
                return self._refuse(source, target, str(rule), start)
            self._notify()
            return self._execute(rule, inflight, start)
        finally:
            self._transition_lock.release()

    def estop(self) -> Outcome:
        """Enter EMERGENCY now and damp the robot; always ends in EMERGENCY, whatever fails.

        success=False means the robot did not acknowledge a Damp: call estop() again to retry.
        """
        start = self._clock()
        with self._state_lock:
            source = self._mode
            preempted = self._inflight
            if preempted is not None:
                preempted.preempted.set()
                self._inflight = None
            direct = source is Mode.HIGH_LEVEL and preempted is None and self._service_known and self._service_active
            connected = self._connected
            self._mode = Mode.EMERGENCY
        notes: list[str] = []
        if connected:  # the fastest shot first, before anything that could delay it
            notes += self._fire_damp_no_reply()
        if preempted is not None:
            notes.append(f"preempted {preempted.source.name}->{preempted.target.name}")
        self._notify()
        with self._estop_lock:
            why = self._estop_sequence(direct=direct, connected=connected, notes=notes)
        duration = self._clock() - start
        detail = f" ({'; '.join(notes)})" if notes else ""
        with self._state_lock:
            if why is None:
                result, message = Result.OK, f"e-stop: Damp acknowledged{detail}"
            else:
                result = Result.FAILED
                message = f"e-stop incomplete: {why}; call estop again to retry{detail}"
                self._last_refusal = message
                self._last_error = why
            record = TransitionRecord(source, Mode.EMERGENCY, result, duration, message)
            self._history.append(record)
        self._emit(record)
        return Outcome(result is Result.OK, Mode.EMERGENCY, message, duration, refused=False)

    # --- internals -------------------------------------------------------------------------------
    def _execute(self, rule: Transition, inflight: _Inflight, start: float) -> Outcome:
        calls = RunPort(self._port, self._note_service, self._sleep, inflight.preempted)
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
        source, target = rule.source.name, rule.target.name
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
                self._mode = rule.target
                result, message = Result.OK, f"{source}->{target}: {rule.description}"
                if selected or (rule.source is Mode.LOW_LEVEL and rule.target is Mode.HIGH_LEVEL):
                    message += f"; {_ZERO_TORQUE_NOTE}"
            mode = self._mode
            record = TransitionRecord(rule.source, rule.target, result, duration, message)
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

    def _estop_sequence(self, *, direct: bool, connected: bool, notes: list[str]) -> str | None:
        """Connect if needed, Damp (after making the service active unless direct). None = damped."""
        calls = RunPort(self._port, self._note_service, self._sleep)
        try:
            if not connected:
                calls.connect()
                self._set_connected()
                notes += self._fire_damp_no_reply()
            if direct:
                try:
                    self._damp(calls)
                    return None
                except Exception as exc:
                    notes.append(f"direct Damp failed ({exc}); making the service active first")
            if ensure_service_active(
                calls,
                timeout_s=self._select_timeout_s,
                poll_interval_s=self._poll_interval_s,
                clock=self._clock,
                sleep=self._sleep,
            ):
                notes.append("SelectMode('ai') sent")
            self._damp(calls)
            return None
        except (RobotError, StepTimeoutError) as exc:
            return str(exc)
        except Exception as exc:
            return f"unexpected {type(exc).__name__} from the robot port: {exc}"

    def _damp(self, calls: RunPort) -> None:
        try:
            calls.damp()
        except Exception:
            with self._state_lock:
                self._damp_confirmed = False
                self._service_known = False  # Damp fails mostly because the service is released
            raise
        with self._state_lock:
            self._damp_confirmed = True

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

    def _note_callback_error(self, name: str, exc: Exception) -> None:
        with self._state_lock:
            self._last_error = f"{name} callback raised {type(exc).__name__}: {exc}"
