"""The body checks evaluated over time: debounce, latching, and whether a latched check is clear.

``evaluate`` is called with every new reading (the node's body watch, 20-100 Hz). A check trips once its
condition has held for its debounce; a HOLD or FAULT reaction then latches until ``clear()`` (the
operator's clear_fault), which is allowed only once every latched check has been clear for
``clear_hold_s``. A latched check that trips again with a stronger reaction (the mode changed) trips
again. A reading that is unknown never trips and never counts as clear.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from dataclasses import dataclass

from g1_mode_manager.core.body.checks import CHECKS, Check, Reaction
from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.modes import Mode


@dataclass(frozen=True)
class Trip:
    """A check that just reached a reaction stronger than the one it had latched."""

    check: str
    reaction: Reaction
    text: str


@dataclass(frozen=True)
class CheckStatus:
    """One check as /diagnostics shows it."""

    check: str
    value: float | None
    threshold: float
    unit: str
    state: str  # ok, tripping (within its debounce), warn, hold, fault, not applicable, no data
    latched: Reaction
    text: str


@dataclass
class _Track:
    over_since: float | None = None  # the condition holds continuously since
    clear_since: float | None = None  # a latched check's condition is false continuously since
    latched: Reaction = Reaction.NONE
    latched_text: str = ""
    value: float | None = None
    readings: BodyReadings | None = None  # the latest, for the check's words on what it judged (Check.detail)
    state: str = "no data"


class BodyMonitor:
    def __init__(self, *, clear_hold_s: float, thresholds: Mapping[str, float] | None = None,
                 checks: tuple[Check, ...] = CHECKS) -> None:
        unknown = set(thresholds or {}) - {c.name for c in checks}
        if unknown:
            raise ValueError(f"unknown body checks: {', '.join(sorted(unknown))}")
        self._checks = checks
        self._thresholds = {c.name: float((thresholds or {}).get(c.name, c.threshold)) for c in checks}
        self._clear_hold_s = clear_hold_s
        self._lock = threading.Lock()
        self._tracks = {c.name: _Track() for c in checks}

    def threshold(self, name: str) -> float:
        return self._thresholds[name]

    def text(self, check: Check, value: float, readings: BodyReadings | None = None) -> str:
        relation = ">" if check.above else "<"
        detail = getattr(readings, check.detail) if check.detail and readings is not None else ""
        return (f"{check.name}: {value:.2f} {check.unit} {relation} {self._thresholds[check.name]:g}"
                + (f" ({detail})" if detail else ""))

    def evaluate(self, readings: BodyReadings, mode: Mode, upright_expected: bool, now: float) -> list[Trip]:
        """One look at the robot; returns the checks whose reaction just grew beyond what they had latched."""
        trips: list[Trip] = []
        with self._lock:
            for check in self._checks:
                track = self._tracks[check.name]
                value = getattr(readings, check.reading)
                track.value = value
                track.readings = readings
                applies = upright_expected or not check.upright_only
                over = applies and value is not None and check.trips(value, self._thresholds[check.name])
                if over:
                    track.clear_since = None
                    if track.over_since is None:
                        track.over_since = now
                else:
                    track.over_since = None
                    if track.latched and track.clear_since is None and (value is not None or not applies):
                        track.clear_since = now
                tripped = over and now - track.over_since >= check.debounce_s  # type: ignore[operator]
                reaction = check.reaction(mode) if tripped else Reaction.NONE
                if reaction >= Reaction.HOLD and reaction > track.latched:
                    track.latched, track.latched_text = reaction, self.text(check, value, readings)  # type: ignore[arg-type]
                    trips.append(Trip(check.name, reaction, track.latched_text))
                track.state = self._state(track, applies, value, over, tripped, reaction)
        return trips

    @staticmethod
    def _state(track: _Track, applies: bool, value: float | None, over: bool, tripped: bool,
               reaction: Reaction) -> str:
        if track.latched:
            return track.latched.name.lower()
        if not applies:
            return "not applicable"
        if value is None:
            return "no data"
        if tripped and reaction is Reaction.WARN:
            return "warn"
        return "tripping" if over else "ok"

    def latched(self, reaction: Reaction) -> tuple[str, ...]:
        """Texts of the checks latched at exactly this reaction (HOLD or FAULT)."""
        with self._lock:
            return tuple(t.latched_text for t in self._tracks.values() if t.latched is reaction)

    def warnings(self) -> tuple[str, ...]:
        with self._lock:
            return tuple(self.text(c, t.value, t.readings) for c in self._checks  # type: ignore[arg-type]
                         if (t := self._tracks[c.name]).state == "warn")

    def states(self) -> tuple[str, ...]:
        """Each check's state (as in statuses), in the order of the checks: no text made, for every step."""
        with self._lock:
            return tuple(t.state for t in self._tracks.values())

    def statuses(self) -> tuple[CheckStatus, ...]:
        with self._lock:
            out = []
            for c in self._checks:
                t = self._tracks[c.name]
                text = t.latched_text or ("" if t.value is None else self.text(c, t.value, t.readings))
                out.append(CheckStatus(c.name, t.value, self._thresholds[c.name], c.unit, t.state, t.latched, text))
            return tuple(out)

    def clearable(self, now: float) -> str:
        """'' if every latched check has been clear for clear_hold_s (or none is latched), else why not."""
        with self._lock:
            waiting = []
            for name, t in self._tracks.items():
                if not t.latched:
                    continue
                if t.clear_since is None:
                    now_text = "no reading" if t.value is None else f"now {t.value:.2f}"
                    waiting.append(f"{name} still active ({t.latched_text}; {now_text})")
                elif now - t.clear_since < self._clear_hold_s:
                    waiting.append(f"{name} clear for only {now - t.clear_since:.1f} s of {self._clear_hold_s:g} s")
            return "; ".join(waiting)

    def any_latched(self) -> bool:
        with self._lock:
            return any(t.latched for t in self._tracks.values())

    def clear(self) -> None:
        """Forget every latched reaction (after clearable() said yes)."""
        with self._lock:
            for t in self._tracks.values():
                t.latched, t.latched_text, t.clear_since = Reaction.NONE, "", None
