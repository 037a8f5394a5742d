"""The flight recorder: the node's own recent past always kept (the flight ring), written as an incident file
when a stop is entered (EMERGENCY, FAULT: the window before it and ``after_s`` after) or when asked
(``~/snapshot``).

The hooks of the node's parts call the adapters below from their own threads; each only builds an event and
appends it to the ring. Deciding that a stop began takes a short lock of this object's own (never held while
writing). Files are written by a thread of their own: nothing on the e-stop path, the body watch or a frame loop
ever waits for a file. A folder that cannot be written is reported (``report()``, the log) and retried, never
raised.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Final

from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.events import LogFn
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.recorder.events import (
    Attempt,
    BodyStep,
    DriveInput,
    EstopStep,
    Kind,
    MoveSent,
    Note,
    ServiceAnswer,
    StatusChange,
)
from g1_mode_manager.core.recorder.incidents import Cause
from g1_mode_manager.core.recorder.ring import RATES_HZ, FlightRing, caps_for
from g1_mode_manager.core.records import MachineStatus, TransitionRecord
from g1_mode_manager.core.velocity import Velocity
from g1_mode_manager.flight_recorder.incident_folder import IncidentFolder

#: An e-stop request this recent names how the EMERGENCY that follows was asked for, s.
ESTOP_VIA_S: Final = 2.0
#: While the folder cannot be written, it is looked at again this often, s.
RECHECK_S: Final = 10.0
#: The ring drops what is older than its window this often (the recorder's thread wakes for it), s.
PRUNE_PERIOD_S: Final = 1.0
_STOPS: Final = {Mode.EMERGENCY: Cause.EMERGENCY, Mode.FAULT: Cause.FAULT}


@dataclass(frozen=True)
class RecorderConfig:
    """No defaults: the node's parameters (node/settings.py) are the one place they are chosen."""

    folder: Path
    enabled: bool  # false: the node's parts are not tapped, no thread runs, ~/snapshot refuses
    window_s: float
    after_s: float
    max_files: int
    max_bytes: int
    frame_rate_hz: float  # joint frames kept per topic and second
    body_rate_hz: float  # the body checks' rate
    node: str  # the node's name, for the files' metadata


@dataclass(frozen=True)
class RecorderReport:
    """What /diagnostics says of the recorder."""

    folder: Path
    enabled: bool = True
    error: str = ""  # why incidents cannot be written now ("" while they can)
    last_file: str = ""
    last_cause: str = ""
    pending: str = ""  # a stop whose incident waits for the rest of its after-window
    written: int = 0
    kept_events: int = 0  # in the ring after its last prune
    kept_bytes: int = 0  # ... and what they take (FlightRing.approx_bytes)


@dataclass
class _Due:
    """An incident to write: a stop's (once ``at`` passed) or a snapshot's (at once)."""

    cause: Cause
    text: str
    mode: Mode
    began: float  # on the recorder's clock
    at: float
    done: threading.Event | None = None  # a snapshot's caller waits for this
    result: tuple[bool, str] = (False, "not written")


def _keep_nothing(_event: object, _at: float | None = None) -> None:
    """``add`` of a recorder that is off."""


class FlightRecorder:
    def __init__(self, config: RecorderConfig, *, log: LogFn, clock: Callable[[], float] = time.monotonic,
                 wall: Callable[[], float] = time.time) -> None:
        self.config = c = config
        rates = {**RATES_HZ, Kind.BODY: c.body_rate_hz, Kind.FRAME: 3.0 * c.frame_rate_hz}
        self.ring = FlightRing(caps_for(c.window_s + c.after_s, rates), clock)
        # what the robot port's recording and every adapter below call; off, nothing is kept
        self.add = self.ring.add if c.enabled else _keep_nothing
        self.frame_period_s = 1.0 / c.frame_rate_hz
        self._folder = IncidentFolder(c.folder, max_files=c.max_files, max_bytes=c.max_bytes)
        self._log = log
        self._clock = clock
        self._wall = wall
        self._lock = threading.Lock()  # guards what follows; never held while a file is written
        self._stop_due: _Due | None = None
        self._snapshots: list[_Due] = []
        self._status: MachineStatus | None = None  # the last status kept
        self._version = -1  # the newest status seen
        self._mode = Mode.UNINITIALIZED  # ... and its mode
        self._estop_via: tuple[str, float] = ("", -math.inf)  # the last e-stop request and when
        self._report = RecorderReport(c.folder, c.enabled)
        self._last_body: BodyReadings | None = None  # body_step's, on the body watch's thread only
        self._last_verdicts: tuple[str, ...] = ()
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name="flight_recorder", daemon=True)

    # --- the hooks' adapters (any thread) --------------------------------------------------------
    def on_status(self, status: MachineStatus) -> None:
        """The mode machine's change listener: every status kept (a repeat of the last once); entering EMERGENCY or
        FAULT makes an incident. Listeners run in several threads: a status older than one seen decides nothing."""
        cause = _STOPS.get(status.mode)
        with self._lock:
            if status == self._status:
                return
            self._status = status
            self.add(StatusChange(status))
            if status.version <= self._version:
                return
            self._version, previous, self._mode = status.version, self._mode, status.mode
            if cause is None or previous is status.mode:
                return
            now = self._clock()
            text = self._cause_text(status, previous, now)
            due = self._stop_due
            if due is None:
                due = self._stop_due = _Due(cause, text, status.mode, now, now + self.config.after_s)
            else:  # a second stop inside the first one's after-window: one incident holds both
                due.text, due.mode, due.at = f"{due.text}; then {text}", status.mode, now + self.config.after_s
            self._report = replace(self._report, pending=due.text)
        self._wake.set()

    def _cause_text(self, status: MachineStatus, previous: Mode, now: float) -> str:
        if status.mode is Mode.FAULT:
            return f"FAULT from {previous.name}: {'; '.join(status.faults)}"
        via, at = self._estop_via
        return f"EMERGENCY from {previous.name}" + (f" ({via})" if now - at <= ESTOP_VIA_S else "")

    def attempt(self, record: TransitionRecord) -> None:
        self.add(Attempt(record))

    def note(self, level: str, text: str) -> None:
        self.add(Note(level, text))

    def service_answer(self, service: str, request: str, success: bool, message: str) -> None:
        self.add(ServiceAnswer(service, request, success, message))

    def estop_step(self, step: str, via: str, detail: str = "") -> None:
        self.add(EstopStep(step, via, detail))
        if step == "request":
            self._estop_via = (via, self._clock())

    def body_step(self, readings: BodyReadings, verdicts: tuple[str, ...], at: float | None = None) -> None:
        """A body watch step that began ``at`` (before it acted on what it read); a step that read nothing new (the
        same readings object) is not kept twice, and unchanged verdicts share one tuple."""
        if readings is self._last_body:
            return
        self._last_body = readings
        if verdicts == self._last_verdicts:
            verdicts = self._last_verdicts
        self._last_verdicts = verdicts
        self.ring.add(BodyStep(readings, verdicts), at)

    def drive_input(self, driver: Driver, vx: float, vy: float, wz: float, taken: bool) -> None:
        self.add(DriveInput(driver.value, vx, vy, wz, taken))

    def move_sent(self, driver: Driver, velocity: Velocity) -> None:
        self.add(MoveSent(driver.value, velocity.vx, velocity.vy, velocity.wz))

    # --- what the node asks --------------------------------------------------------------------------
    def snapshot(self, timeout_s: float = 10.0) -> tuple[bool, str]:
        """Write the window before now; (True, the file) once written, else (False, why not)."""
        if not self.config.enabled:
            return False, "the flight recorder is off (recorder_enabled false)"
        if not self._thread.is_alive():
            return False, "the flight recorder is not running"
        now, done = self._clock(), threading.Event()
        with self._lock:
            due = _Due(Cause.SNAPSHOT, "~/snapshot", self._mode, now, now, done)
            self._snapshots.append(due)
        self._wake.set()
        if not done.wait(timeout_s):
            return False, f"the incident was not written within {timeout_s:g} s"
        return due.result

    def report(self) -> RecorderReport:
        with self._lock:
            return self._report

    def warnings(self) -> tuple[str, ...]:
        """For ~/mode's warnings: why no incident can be written, while none can."""
        error = self.report().error
        return (f"recorder: no incident can be written: {error}",) if error else ()

    def start(self) -> None:
        if self.config.enabled:
            self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        """A stop's incident still waiting for its after-window is written now, with what came so far."""
        self._stopping.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    # --- the writer thread -----------------------------------------------------------------------
    def _run(self) -> None:
        self._set_error(self._folder.check())
        checked_at = self._clock()
        while True:
            self._wake.wait(self._wait_s())
            self._wake.clear()
            stopping = self._stopping.is_set()
            with self._lock:
                ready, self._snapshots = self._snapshots, []
                stop = self._stop_due
                if stop is not None and (stopping or self._clock() >= stop.at):
                    ready.append(stop)
                    self._stop_due = None
                    self._report = replace(self._report, pending="")
            for due in ready:
                due.result = self._write(due)
                if due.done is not None:
                    due.done.set()
            if stopping:
                return
            if not ready and self.report().error and self._clock() - checked_at >= RECHECK_S:
                self._set_error(self._folder.check())
                checked_at = self._clock()
            self._prune()

    def _wait_s(self) -> float:
        with self._lock:
            stop = self._stop_due
        return PRUNE_PERIOD_S if stop is None else min(PRUNE_PERIOD_S, max(0.0, stop.at - self._clock()))

    def _prune(self) -> None:
        """What no incident can hold any more goes: older than a window before now (a snapshot's), and before a
        pending stop's window (its file holds the window before its first stop however long later stops put it
        off), with a period's slack."""
        with self._lock:
            stop = self._stop_due
        since = self._clock() if stop is None else min(self._clock(), stop.began)
        self.ring.prune(since - self.config.window_s - 2.0 * PRUNE_PERIOD_S)
        kept, kept_bytes = sum(self.ring.counts().values()), self.ring.approx_bytes()
        with self._lock:
            self._report = replace(self._report, kept_events=kept, kept_bytes=kept_bytes)

    def _write(self, due: _Due) -> tuple[bool, str]:
        end = self._clock()
        start = due.began - self.config.window_s
        offset = self._wall() - end  # this clock -> UNIX time, for the file's times
        metadata = {"cause": due.text, "mode": due.mode.name, "began": f"{due.began + offset:.3f}",
                    "window_s": f"{self.config.window_s:g}", "after_s": f"{end - due.began:.3f}",
                    "node": self.config.node}
        try:
            path, count = self._folder.write(due.began + offset, due.cause, lambda: self.ring.entries(start, end),
                                             metadata, to_unix=lambda t: t + offset)
        except Exception as exc:  # a full disk or a folder gone: reported, never raised into the node
            why = self._folder.check() or f"{type(exc).__name__}: {exc}"  # the folder's fault, said as its check says it
            self._set_error(why)
            return False, f"no incident written: {why}"
        with self._lock:
            self._report = replace(self._report, error="", last_file=str(path), last_cause=due.text,
                                   written=self._report.written + 1)
        self._log("info", f"flight recorder: incident written to {path} ({due.text}; {count} messages)")
        return True, str(path)

    def _set_error(self, error: str) -> None:
        """Logged when it changes: a folder that stays unwritable is looked at every RECHECK_S, logged once."""
        with self._lock:
            changed, self._report = error != self._report.error, replace(self._report, error=error)
        if error and changed:
            self._log("error", f"flight recorder: no incident can be written: {error}")
