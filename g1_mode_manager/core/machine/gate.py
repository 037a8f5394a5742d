"""The forward gate and the robot-changing calls in flight.

The gate is one lock held around "is this allowed now?" plus the one write that follows (a Move
request, an arm_sdk or lowcmd frame), never around a wait for the robot's reply. An e-stop and a
transition take it to change the mode, so nothing that was allowed before they began can be written
after they did, and a slow acknowledgement never holds them up.

A call that changes the robot and blocks (SelectMode, ReleaseMode, a loco command) is registered as
in flight atomically with its check; the e-stop waits for such calls to land before it believes the
robot damped, and a call that lands after an e-stop began makes the supervision re-verify at once.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from g1_mode_manager.core.machine.state import MachineState
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.preemption import Preempted


@dataclass(frozen=True)
class ForwardDecision:
    """What the forward gate judged, for the one write under it: whether it may pass, and the mode it saw.

    The mode is the one the gate read with its verdict, so the code under the gate (the link check, a drop's
    reason) takes it instead of asking the machine again."""

    allowed: bool
    mode: Mode

    def __bool__(self) -> bool:
        # an object is always true: `if decision:` would forward in every mode, so it must fail loudly
        raise TypeError("a ForwardDecision is no bool: ask its .allowed")


class ForwardGate:
    """The forward lock, and the count of robot-changing calls in flight (guarded by the state's lock)."""

    def __init__(self, state: MachineState) -> None:
        self._state = state
        self.lock = threading.Lock()  # a check and one write; the e-stop's registration; a transition's start
        self._landed = threading.Condition(state.lock)
        self._changing_calls = 0  # guarded by state.lock

    # --- what relays and loco commands go through ------------------------------------------------
    @contextmanager
    def forwarding(self, predicate: Callable[[Mode], bool]) -> Iterator[ForwardDecision]:
        """Held around one write; yields the decision (may it pass now, in which mode), read with one take of
        the state's lock. Keep the body to the write itself: the wait for a reply belongs after the block."""
        state = self._state
        with self.lock:
            with state.lock:
                decision = ForwardDecision(state.allows_locked(predicate), state.mode)
            yield decision

    @contextmanager
    def robot_call(self, allowed: Callable[[Mode], bool], *, stopping: bool = False) -> Iterator[bool]:
        """Around a blocking robot-changing call (a loco command): yields whether it may be sent. The gate
        is held only for the check and the registration; the call itself runs outside it. ``stopping``: the
        call stops the robot (damp), so a body check's hold does not refuse it."""
        state = self._state
        with self.lock, state.lock:
            ok = state.allows_locked(allowed, stopping=stopping)
            gen = state.estop_gen
            if ok:
                self._changing_calls += 1
        try:
            yield ok
        finally:
            if ok:
                self._call_landed(gen)

    @contextmanager
    def transition_call(self, preempted: threading.Event | None) -> Iterator[None]:
        """A transition's robot-changing call (SelectMode, ReleaseMode), registered as in flight; raises
        Preempted if the run was preempted before it was sent."""
        with self._state.lock:
            if preempted is not None and preempted.is_set():
                raise Preempted("robot call")
            gen = self._state.estop_gen
            self._changing_calls += 1
        try:
            yield
        finally:
            self._call_landed(gen)

    def _call_landed(self, gen: int) -> None:
        with self._state.lock:
            self._changing_calls -= 1
            if self._state.estop_gen != gen:
                self._state.late_landing = True
            self._landed.notify_all()

    # --- what the e-stop and the supervision ask -------------------------------------------------
    def wait_calls_landed(self, deadline: float) -> bool:
        """Wait until no robot-changing call is in flight (each ends by its reply or its timeout)."""
        clock = self._state.clock
        with self._state.lock:
            while self._changing_calls > 0:
                left = deadline - clock()
                if left <= 0:
                    return False
                self._landed.wait(min(left, 0.05))
            return True

    def drain_writes(self, deadline: float) -> bool:
        """Wait until a write that was under way when the e-stop registered has finished.

        Registration waits only ``forward_wait_s`` for the gate (the e-stop is never held up by a relay);
        a write allowed before it may still be on its way, e.g. an arm frame whose thread was descheduled.
        No new write passes after registration, so once the gate is free only damping reaches the robot,
        and the sequence's Damp lands after that last write."""
        if not self.lock.acquire(timeout=max(0.0, deadline - self._state.clock())):
            return False
        self.lock.release()
        return True
