"""What every part of the mode machine shares: its fields, the one short lock that guards them, and the
listeners it reports to.

The lock guards decisions and field updates only; nothing waits for the robot while holding it. The
listeners (record, change, alarm, leave) run outside it, possibly from several threads at once; an
exception from one is kept in ``last_error`` and never interrupts a transition or an e-stop.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.records import MachineStatus, TransitionRecord

LeaveListener = Callable[[Mode, Mode], None]
AlarmListener = Callable[[str], None]


@dataclass
class Inflight:
    """The transition being executed right now."""

    source: Mode
    target: Mode
    preempted: threading.Event = field(default_factory=threading.Event)


class MachineState:
    """The machine's fields; every read or write of them holds ``lock`` (a plain, short lock)."""

    def __init__(
        self,
        *,
        clock: Callable[[], float],
        on_record: Callable[[TransitionRecord], None] | None,
        on_change: Callable[[MachineStatus], None] | None,
        on_alarm: AlarmListener | None,
        history_size: int,
    ) -> None:
        self.clock = clock
        self.lock = threading.Lock()
        self._on_record = on_record
        self._on_change = on_change
        self._on_alarm = on_alarm
        self._leave_listeners: list[LeaveListener] = []
        # guarded by lock
        self.mode = Mode.UNINITIALIZED
        self.inflight: Inflight | None = None
        self.connected = False
        self.service_known = False
        self.service_active = False
        self.damp_confirmed = False
        self.last_refusal = ""
        self.last_error = ""
        self.mismatch = ""  # why the robot no longer matches the mode; "" while it does
        self.version = 0  # grows with every change a status snapshot shows
        self.estop_gen = 0  # grows with every e-stop registration
        self.reasserts = 0
        self.faults: tuple[str, ...] = ()  # the body checks that put the robot in FAULT
        self.holds: tuple[str, ...] = ()  # body checks holding motion in the current mode
        self.late_landing = False  # a robot-changing call returned after an e-stop began
        self.next_belief = 0.0  # when the supervision next checks the robot against the mode
        self.verified_at = float("-inf")  # when an e-stop sequence last saw the robot damped
        self.next_verify = 0.0  # when the supervision next re-verifies the robot in EMERGENCY
        self.history: deque[TransitionRecord] = deque(maxlen=history_size)

    # --- reading ---------------------------------------------------------------------------------
    def status(self) -> MachineStatus:
        with self.lock:
            return self.status_locked()

    def status_locked(self) -> MachineStatus:
        inflight = self.inflight
        return MachineStatus(
            mode=self.mode,
            transition_in_progress=inflight is not None,
            transition_target=inflight.target if inflight is not None else None,
            service_known=self.service_known,
            service_active=self.service_active,
            damp_confirmed=self.damp_confirmed,
            last_refusal=self.last_refusal,
            last_error=self.last_error,
            robot_mismatch=self.mismatch,
            reasserts=self.reasserts,
            version=self.version,
            faults=self.faults,
            holds=self.holds,
        )

    def allows_locked(self, predicate: Callable[[Mode], bool], *, stopping: bool = False) -> bool:
        """Commands pass only in a mode that allows them, never while a transition runs, never while the
        robot was seen not to match the mode; nothing but a stopping command while a body check holds."""
        return (self.inflight is None and not self.mismatch and (stopping or not self.holds)
                and predicate(self.mode))

    def allows(self, predicate: Callable[[Mode], bool]) -> bool:
        with self.lock:
            return self.allows_locked(predicate)

    def current_gen(self) -> int:
        with self.lock:
            return self.estop_gen

    # --- what the robot told us ------------------------------------------------------------------
    def note_service(self, known: bool, active: bool, preempted: threading.Event | None) -> None:
        with self.lock:
            if preempted is not None and preempted.is_set():
                return  # a preempted run's late answers must not overwrite the e-stop's knowledge
            self.service_known = known
            self.service_active = known and active

    def set_connected(self) -> None:
        with self.lock:
            self.connected = True

    # --- reporting -------------------------------------------------------------------------------
    def add_leave_listener(self, listener: LeaveListener) -> None:
        self._leave_listeners.append(listener)

    def leaving(self, source: Mode, target: Mode) -> None:
        for listener in self._leave_listeners:
            self._call("leave listener", listener, source, target)

    def emit(self, record: TransitionRecord) -> None:
        """Hand a record (already in the history) to the record listener, then a fresh status."""
        self._call("on_record", self._on_record, record)
        self.notify()

    def notify(self) -> None:
        if self._on_change is not None:
            self._call("on_change", self._on_change, self.status())

    def alarm(self, text: str) -> None:
        with self.lock:
            self.last_error = text
            self.version += 1
        self._call("on_alarm", self._on_alarm, text)
        self.notify()

    def _call(self, name: str, listener: Callable[..., object] | None, *args: object) -> None:
        """A listener's exception is kept in last_error; it never reaches the transition or the e-stop."""
        if listener is None:
            return
        try:
            listener(*args)
        except Exception as exc:
            self.note_callback_error(name, exc)

    def note_callback_error(self, name: str, exc: Exception) -> None:
        with self.lock:
            self.last_error = f"{name} callback raised {type(exc).__name__}: {exc}"
