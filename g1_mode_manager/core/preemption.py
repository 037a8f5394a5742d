"""The port as one run of the machine sees it: preemptible, and reporting what it learns.

A transition may be blocked inside a slow robot call when an e-stop arrives. The e-stop cannot
interrupt that call, but once it returns the transition must not touch the robot again: every call
(and every sleep) of a preemptible run checks the run's flag before and after, and raises
:class:`Preempted` once it is set.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from g1_mode_manager.core.port import ModePort

#: note_service(known, active, preempted_flag): the machine's record of the high-level service.
NoteService = Callable[[bool, bool, "threading.Event | None"], None]


class Preempted(Exception):  # noqa: N818 (named for what happened, as in the design)
    """Internal: an e-stop preempted this run; the run must stop without further robot calls."""


class RunPort:
    """A ModePort wrapper for one transition or e-stop sequence (preemptible if given a flag)."""

    def __init__(
        self,
        port: ModePort,
        note_service: NoteService,
        sleep: Callable[[float], None],
        preempted: threading.Event | None = None,
    ) -> None:
        self._port = port
        self._note_service = note_service
        self._sleep = sleep
        self._preempted = preempted

    def _check(self, what: str) -> None:
        if self._preempted is not None and self._preempted.is_set():
            raise Preempted(what)

    def connect(self) -> None:
        self._check("connect")
        self._port.connect()
        self._check("connect")

    def check_mode(self) -> str:
        self._check("check_mode")
        name = self._port.check_mode()
        self._check("check_mode")
        self._note_service(True, bool(name), self._preempted)
        return name

    def select_mode(self, name: str) -> None:
        self._check("select_mode")
        self._note_service(False, False, self._preempted)  # unknown until confirmed by CheckMode
        self._port.select_mode(name)
        self._check("select_mode")

    def release_mode(self) -> None:
        self._check("release_mode")
        self._note_service(False, False, self._preempted)
        self._port.release_mode()
        self._check("release_mode")

    def damp(self) -> None:
        self._check("damp")
        self._port.damp()
        self._check("damp")

    def damp_no_reply(self) -> None:
        self._check("damp_no_reply")
        self._port.damp_no_reply()
        self._check("damp_no_reply")

    def sleep(self, seconds: float) -> None:
        self._check("sleep")
        self._sleep(seconds)
        self._check("sleep")
