"""FAULT, the protective stop of the body checks, and the operator's clear.

- ``enter``: a body check's FAULT reaction. From IDLE, HIGH_LEVEL or LOW_LEVEL (also during a transition,
  which it preempts as the e-stop does): registered under the forward gate, a DampNoReply, then the
  e-stop's damping sequence in a thread of its own (the caller, the body watch, never waits for the robot). Leaving
  LOW_LEVEL sends damping frames at once (the relay's leave listener), HIGH_LEVEL a StopMove. In FAULT the
  supervision keeps the robot damped as in EMERGENCY, and an e-stop still overrides it.
- ``hold``: a body check's HOLD reaction: the mode is kept, nothing but stopping passes the gate.
- ``clear``: FAULT -> IDLE (or holds released, the mode kept) only once every latched check has been
  clear long enough and the robot was verified damped; it never restarts motion.
"""

from __future__ import annotations

from collections.abc import Callable

from g1_mode_manager.core.machine.estop import Estop
from g1_mode_manager.core.machine.gate import ForwardGate
from g1_mode_manager.core.machine.state import MachineState
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.records import Outcome, Result, TransitionRecord
from g1_mode_manager.core.transitions import Transition, Trigger, lookup


def _may_fault(mode: Mode) -> bool:
    return isinstance(lookup(mode, Mode.FAULT, Trigger.BODY_CHECK), Transition)


class FaultStop:
    def __init__(self, state: MachineState, gate: ForwardGate, estop: Estop) -> None:
        self._state = state
        self._gate = gate
        self._estop = estop

    def enter(self, faults: tuple[str, ...]) -> bool:
        """Enter FAULT for these checks (their texts); True if this call entered it. Already in FAULT: the
        faults are added. In UNINITIALIZED or EMERGENCY: nothing (there is no robot yet / a stronger stop)."""
        state = self._state
        start = state.clock()
        with state.lock:
            if state.mode is Mode.FAULT:
                state.faults = tuple(dict.fromkeys((*state.faults, *faults)))
                state.version += 1
                added = True
            else:
                added = False
        if added:
            state.notify()
            return False
        registration = self._estop.register(Mode.FAULT, faults=faults, allowed=_may_fault)
        if registration is None:
            return False
        registration.notes.extend(self._estop.shot())  # Damp at once where the sport service answers
        self._estop.start_sequences()
        detail = "; ".join(registration.notes)
        message = f"protective stop: {', '.join(faults)}; damping sequence running" + (f" ({detail})" if detail else "")
        self._record(registration.source, Mode.FAULT, Result.REGISTERED, start, message)
        return True

    def hold(self, holds: tuple[str, ...]) -> None:
        """Hold motion in the current mode for these checks (no effect in EMERGENCY or FAULT)."""
        state = self._state
        with self._gate.lock, state.lock:  # under the gate: no write allowed before it passes after it
            if state.mode in (Mode.EMERGENCY, Mode.FAULT, Mode.UNINITIALIZED):
                return
            state.holds = tuple(dict.fromkeys((*state.holds, *holds)))
            state.version += 1
        state.alarm(f"motion held in {state.mode.name}: {', '.join(holds)}")

    def clear(self, not_clear_because: Callable[[], str], release: Callable[[], None]) -> Outcome:
        """The operator's clear. ``not_clear_because()``: '' once every latched check has been clear long
        enough; ``release()``: forget the latched checks (called only when this succeeds)."""
        state = self._state
        start = state.clock()
        with state.lock:
            source, held, confirmed = state.mode, bool(state.holds), state.damp_confirmed
        rule = lookup(source, Mode.IDLE, Trigger.CLEAR_FAULT)
        if not isinstance(rule, Transition) and not held:
            return self._refused(source, str(rule), start)
        why = not_clear_because()
        if why:
            return self._refused(source, f"not cleared: {why}", start)
        if isinstance(rule, Transition) and not confirmed:
            return self._refused(source, "not cleared: the protective stop has not yet seen the robot damped", start)
        with self._gate.lock, state.lock:
            if state.mode is not source:  # an e-stop (or another clear) came first
                mode = state.mode
            else:
                release()
                state.holds = ()
                if isinstance(rule, Transition):  # damp_confirmed was the stop's claim: IDLE makes none
                    state.mode, state.faults, state.damp_confirmed = Mode.IDLE, (), False
                state.version += 1
                mode = None
        if mode is not None:
            return self._refused(mode, f"not cleared: the mode changed to {mode.name}", start)
        if isinstance(rule, Transition):
            return self._record(source, Mode.IDLE, Result.OK, start, f"FAULT->IDLE: {rule.description}")
        return self._record(source, source, Result.OK, start, f"holds released; still in {source.name}, nothing restarted")

    def _refused(self, source: Mode, reason: str, start: float) -> Outcome:
        state = self._state
        with state.lock:
            state.last_refusal = reason
        return self._record(source, source, Result.REFUSED, start, reason)

    def _record(self, source: Mode, target: Mode, result: Result, start: float, message: str) -> Outcome:
        state = self._state
        record = TransitionRecord(source, target, result, state.clock() - start, message)
        with state.lock:
            state.history.append(record)
            state.version += 1
            mode = state.mode
        state.emit(record)
        return Outcome(result in (Result.OK, Result.REGISTERED), mode, message, record.duration_s,
                       refused=result is Result.REFUSED)
