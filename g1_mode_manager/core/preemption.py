"""The port as one run of the machine sees it: preemptible, and reporting what it learns.

A transition may be blocked inside a slow robot call when an e-stop arrives. The e-stop cannot
interrupt that call, but once it returns the transition must not touch the robot again: every call
(and every sleep) of a preemptible run checks the run's flag before and after, and raises
:class:`Preempted` once it is set. A call that changes the robot (SelectMode, ReleaseMode) is also
registered as in flight, atomically with that check, so an e-stop knows to wait for it to land
before it believes the robot damped.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext

from g1_mode_manager.core.port import ModePort
from g1_mode_manager.core.service_steps import StepTimeoutError

#: note_service(known, active, preempted_flag): the machine's record of the high-level service.
NoteService = Callable[[bool, bool, "threading.Event | None"], None]
#: changing_call(preempted_flag): context around a robot-changing call; raises Preempted if the flag is set.
ChangingCall = Callable[["threading.Event | None"], AbstractContextManager[object]]


class Preempted(Exception):  # noqa: N818 (named for what happened, as in the design)
    """Internal: an e-stop preempted this run; the run must stop without further robot calls."""


def _untracked(_flag: threading.Event | None) -> AbstractContextManager[object]:
    return nullcontext()


class RunPort:
    """A ModePort wrapper for one transition or e-stop sequence (preemptible if given a flag).

    ``call_timeout_s`` bounds the loco calls (Damp, GetFsmId), ``select_timeout_s`` the motion
    switcher's (CheckMode, SelectMode, ReleaseMode: seconds on a robot). None: the port's defaults.
    ``until`` (a time on ``clock``) caps every call's timeout to the time left before it, and refuses a call
    once it has passed (StepTimeoutError): the e-stop's answer must come by then whatever the robot does.
    """

    def __init__(
        self,
        port: ModePort,
        note_service: NoteService,
        sleep: Callable[[float], None],
        preempted: threading.Event | None = None,
        *,
        changing_call: ChangingCall = _untracked,
        call_timeout_s: float | None = None,
        select_timeout_s: float | None = None,
        until: float | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._port = port
        self._note_service = note_service
        self._sleep = sleep
        self._preempted = preempted
        self._changing_call = changing_call
        self._call_timeout_s = call_timeout_s
        self._select_timeout_s = select_timeout_s
        self._until = until
        self._clock = clock
        #: SwitchToUserCtrl was answered 0 by the robot (a preemption seen after it cannot undo the switch)
        self.user_ctrl_switch_answered = False

    def _timeout(self, configured: float | None, what: str) -> float | None:
        if self._until is None:
            return configured
        left = self._until - self._clock()
        if left <= 0.0:
            raise StepTimeoutError(f"{what} not sent: the time budget is spent")
        return left if configured is None else min(configured, left)

    def preempted(self) -> bool:
        """An e-stop preempted this run (the next robot call or sleep raises Preempted)."""
        return self._preempted is not None and self._preempted.is_set()

    def _check(self, what: str) -> None:
        if self.preempted():
            raise Preempted(what)

    def connect(self) -> None:
        self._check("connect")
        self._port.connect()
        self._check("connect")

    def check_mode(self) -> str:
        self._check("check_mode")
        name = self._port.check_mode(timeout_s=self._timeout(self._select_timeout_s, "CheckMode"))
        self._check("check_mode")
        self._note_service(True, bool(name), self._preempted)
        return name

    def select_mode(self, name: str) -> None:
        self._check("select_mode")
        self._note_service(False, False, self._preempted)  # unknown until confirmed by CheckMode
        with self._changing_call(self._preempted):
            self._port.select_mode(name, timeout_s=self._timeout(self._select_timeout_s, "SelectMode"))
        self._check("select_mode")

    def release_mode(self) -> None:
        self._check("release_mode")
        self._note_service(False, False, self._preempted)
        with self._changing_call(self._preempted):
            self._port.release_mode(timeout_s=self._timeout(self._select_timeout_s, "ReleaseMode"))
        self._check("release_mode")

    def switch_to_user_ctrl(self) -> None:
        """SwitchToUserCtrl (user_ctrl path): robot-changing, so registered as in flight."""
        self._check("switch_to_user_ctrl")
        with self._changing_call(self._preempted):
            self._port.switch_to_user_ctrl(timeout_s=self._timeout(self._call_timeout_s, "SwitchToUserCtrl"))  # type: ignore[attr-defined]
        self.user_ctrl_switch_answered = True
        self._check("switch_to_user_ctrl")

    def switch_to_internal_ctrl(self, target: int) -> None:
        """SwitchToInternalCtrl(target) (user_ctrl path); in flight like SwitchToUserCtrl."""
        self._check("switch_to_internal_ctrl")
        with self._changing_call(self._preempted):
            self._port.switch_to_internal_ctrl(target, timeout_s=self._timeout(  # type: ignore[attr-defined]
                self._call_timeout_s, "SwitchToInternalCtrl"))
        self._check("switch_to_internal_ctrl")

    def damp(self) -> None:
        self._check("damp")
        self._port.damp(timeout_s=self._timeout(self._call_timeout_s, "Damp"))
        self._check("damp")

    def get_fsm_id(self) -> int:
        self._check("get_fsm_id")
        fsm_id = self._port.get_fsm_id(timeout_s=self._timeout(self._call_timeout_s, "GetFsmId"))
        self._check("get_fsm_id")
        return fsm_id

    def sleep(self, seconds: float) -> None:
        self._check("sleep")
        self._sleep(seconds)
        self._check("sleep")
