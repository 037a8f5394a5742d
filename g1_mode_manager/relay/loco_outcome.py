"""A loco command's outcome: what the robot shows after the command, read back from the robot itself.

The robot's return code says the request was accepted, not that anything happened (firmware 1.5.3 answers
0 to SetFsmId(500) and stays where it is). So each verb names the state it is judged by (core/loco_verbs.py)
and this waits, bounded, until the robot shows it: rt/sportmodestate for fsm ids and arm tasks (only
samples taken after the send count) and, for a posture verb, the posture read from the robot's body (the
body watch's reading); GetBalanceMode and GetStandHeight for the rest. A posture verb whose robot kept its fsm
and posture throughout is told apart: it accepted the command and did not move. The wait holds no lock and
no gate: it ends early, as "preempted", when the mode changes under it (an e-stop first).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from g1_mode_manager.core.loco_verbs import (
    BalanceShown,
    Expected,
    FsmShown,
    NotReadable,
    StandHeightShown,
    TaskShown,
)
from g1_mode_manager.core.port import RobotError, RobotPort, SportState
from g1_mode_manager.core.posture import NO_READING, Posture, PostureReading
from g1_mode_manager.protocol.fsm import FsmMode

#: How often rt/sportmodestate is looked at (it arrives at 50 Hz), and how often a getter is asked (an RPC).
STATE_POLL_S = 0.005
GETTER_POLL_S = 0.05
#: A getter's own timeout while waiting: short, so that one lost reply does not eat the whole wait.
GETTER_TIMEOUT_S = 0.5
#: A task_time may lead the time since the send by this much (the robot's and this clock's sampling).
TASK_TIME_SLACK_S = 0.05


@dataclass(frozen=True)
class Seen:
    """``ok``: the outcome was seen, ``after_s`` after the send began (else: how long was waited);
    ``shown``: what the robot last showed, in words; ``preempted``: why the wait ended early, or None;
    ``still``: a posture verb's robot showed the fsm and posture it had before the send all along."""

    ok: bool
    after_s: float
    shown: str
    preempted: str | None = None
    still: bool = False


@dataclass(frozen=True)
class Start:
    """Where a posture verb's robot was before the send: its fsm and posture."""

    fsm_id: int
    posture: Posture


@dataclass(frozen=True)
class _Look:
    """One look at the robot: the outcome seen, what it showed, and whether that was where it started (None:
    nothing fresh to compare)."""

    ok: bool
    shown: str
    at_start: bool | None = None


class Preemption:
    """Set, once, by whoever changes the mode under a waiting command; the first reason wins."""

    def __init__(self) -> None:
        self._event = threading.Event()
        self.reason: str | None = None

    def preempt(self, reason: str) -> None:
        if not self._event.is_set():
            self.reason = reason
            self._event.set()

    def wait(self, seconds: float) -> bool:
        return self._event.wait(seconds)

    @property
    def is_set(self) -> bool:
        return self._event.is_set()


class OutcomeWatch:
    """Waits for one verb's outcome on ``port``; remembers the stand height extremes it verified."""

    def __init__(self, port: RobotPort, *, timeout_s: float, motion_timeout_s: float,
                 get_up_timeout_s: float | None = None, posture: Callable[[], PostureReading] = lambda: NO_READING,
                 clock: Callable[[], float] = time.monotonic) -> None:
        get_up_timeout_s = motion_timeout_s if get_up_timeout_s is None else get_up_timeout_s
        if not timeout_s > 0 or not motion_timeout_s > 0 or not get_up_timeout_s > 0:
            raise ValueError("outcome timeouts must be > 0")
        self._port = port
        self.timeout_s = float(timeout_s)
        self.motion_timeout_s = float(motion_timeout_s)
        self.get_up_timeout_s = float(get_up_timeout_s)
        self._posture = posture  # the body watch's reading: a posture verb is done only in its posture
        self._clock = clock
        self._stand_extremes: dict[bool, float] = {}  # highest? -> the height a verified command left

    def limit_s(self, expected: Expected) -> float:
        if isinstance(expected, FsmShown) and expected.get_up:
            return self.get_up_timeout_s
        return self.motion_timeout_s if isinstance(expected, FsmShown) and expected.motion else self.timeout_s

    def before(self, expected: Expected) -> float | Start | None:
        """What must be known before the send: the stand height it must move from (None if unreadable), or
        where a posture verb's robot starts from.

        For the verbs judged on rt/sportmodestate, it takes what has arrived so far: the port stamps a sample
        when it is taken, so a sample from before the send must not wait in the reader to be taken after it.
        """
        if isinstance(expected, FsmShown | TaskShown):
            state = self._port.sport_state()
            if state is None or not isinstance(expected, FsmShown) or expected.posture is None:
                return None
            return Start(state.fsm_id, self._posture().posture)
        if not isinstance(expected, StandHeightShown):
            return None
        try:
            return self._port.get_stand_height(GETTER_TIMEOUT_S)
        except RobotError:
            return None

    def wait(self, expected: Expected, sent_at: float, before: float | Start | None, preemption: Preemption) -> Seen:
        """Block until the robot shows ``expected``, the limit passes or ``preemption`` is set."""
        if isinstance(expected, NotReadable):
            return Seen(False, 0.0, f"not verified: {expected.why}")
        limit = self.limit_s(expected)
        poll = GETTER_POLL_S if isinstance(expected, BalanceShown | StandHeightShown) else STATE_POLL_S
        look = _Look(False, "nothing yet")
        stayed: bool | None = None  # every fresh look showed the start: None before the first one
        while True:
            look = self._look(expected, sent_at, before, look.shown)
            if look.at_start is not None:
                stayed = look.at_start and stayed is not False
            elapsed = self._clock() - sent_at
            if look.ok:
                return Seen(True, elapsed, look.shown)
            if elapsed >= limit:
                return Seen(False, elapsed, look.shown, still=bool(stayed))
            if preemption.wait(min(poll, limit - elapsed)):
                return Seen(False, self._clock() - sent_at, look.shown, preemption.reason)

    def _look(self, expected: Expected, sent_at: float, before: float | Start | None, shown: str) -> _Look:
        match expected:
            case FsmShown():
                state = self._fresh_state(sent_at)
                if state is None:
                    return _Look(False, shown)
                moving = ", still moving" if state.fsm_mode == FsmMode.DYNAMIC else ""
                shown = f"fsm {state.fsm_id} (fsm_mode {state.fsm_mode}{moving})"
                if expected.posture is None:
                    return _Look(expected.reached(state.fsm_id, state.fsm_mode, Posture.UNKNOWN), shown)
                # the fsm alone does not say where the body is: a firmware that shows 702 static on a robot still
                # on the floor has not got it up, and 706 static may be either end of its motion
                reading = self._posture()
                at_start = (None if not isinstance(before, Start)
                            else state.fsm_id == before.fsm_id and reading.posture is before.posture)
                return _Look(expected.reached(state.fsm_id, state.fsm_mode, reading.posture),
                             f"{shown}, {reading.describe()}", at_start)
            case TaskShown(task_id=task_id):
                state = self._fresh_state(sent_at)
                if state is None:
                    return _Look(False, shown)
                received_after_send = self._clock() - state.age_s - sent_at
                ok = (state.task_id == task_id and state.task_time > 0.0
                      and state.task_time <= received_after_send + TASK_TIME_SLACK_S)
                task = f"task {state.task_id} at {state.task_time:.2f} s" if state.task_time > 0 else "no arm task"
                return _Look(ok, task)
            case BalanceShown(mode=mode):
                try:
                    got = self._port.get_balance_mode(GETTER_TIMEOUT_S)
                except RobotError as exc:
                    return _Look(False, str(exc))
                return _Look(got == mode, f"balance mode {got}")
            case StandHeightShown(highest=highest):
                try:
                    got = self._port.get_stand_height(GETTER_TIMEOUT_S)
                except RobotError as exc:
                    return _Look(False, str(exc))
                if before is None or isinstance(before, Start):
                    return _Look(False, f"stand height {got:.3f} (its value before the command could not be read)")
                moved = got > before if highest else got < before
                at_extreme = self._stand_extremes.get(highest) == got == before
                if moved or at_extreme:
                    self._stand_extremes[highest] = got
                return _Look(moved or at_extreme, f"stand height {got:.3f} (before: {before:.3f})")
            case _:
                raise TypeError(f"unknown outcome {expected!r}")

    def _fresh_state(self, sent_at: float) -> SportState | None:
        """The last rt/sportmodestate if it arrived after ``sent_at`` (one from before cannot show an outcome)."""
        state = self._port.sport_state()
        if state is None or self._clock() - state.age_s <= sent_at:
            return None
        return state
