"""The Recover button: the recovery sequence g1ctl recover runs (core/recovery.py), started by an operator.

``recover()`` waits for each step's verified answer (a get-up takes seconds), and the web server's event loop must
go on serving every page meanwhile, an e-stop first. So the sequence runs in a thread of its own and asks each step
through the event loop, as a mode or loco button's call is made; what happens comes back to the loop to be shown. One
recovery at a time for all pages together: a second start is refused with who runs which step, never queued.
An e-stop is not this module's business: the node answers the waiting step "preempted by e-stop", and the
sequence stops there.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from g1_mode_manager.core.recovery import BALANCE_STAND, DAMP, GET_UP, GET_UPS, HIGH_LEVEL, STEPS, StepResult, recover

#: A step's answer as the console's service call gives it: success and message always, code and outcome_s for a
#: call the node answered.
Answer = dict[str, Any]


@dataclass(frozen=True)
class _Reply:
    """What recover() reads of an answer (core.recovery.Answer)."""

    success: bool
    message: str


#: The step of the sequence each call belongs to, as the pages list them.
_STEP_OF: dict[str, str] = {"set_mode": HIGH_LEVEL, DAMP: DAMP, BALANCE_STAND: BALANCE_STAND,
                            **dict.fromkeys(GET_UPS.values(), GET_UP)}


class _Robot:
    """The node as recover() sees it (core.recovery.RecoveryRobot), each call made on the event loop."""

    def __init__(self, call: Callable[[str, str], _Reply], mode: Callable[[], tuple[str, str] | None]) -> None:
        self._call = call
        self.mode = mode

    def set_mode(self, mode: str) -> _Reply:
        return self._call("set_mode", mode)

    def loco(self, verb: str) -> _Reply:
        return self._call("loco", verb)


@dataclass
class _Run:
    by: str
    started: float
    step: str = ""  # the step asked last ("" before the first)


class RecoveryRunner:
    """Starts the sequence for a page and tells every page each step as it is asked and answered.

    ``ask(service, argument)`` calls ~/set_mode (argument: the mode) or ~/loco_command (the verb) on the event loop;
    ``tell(event)`` sends an event to every page. Both are called on the event loop's thread, as is everything here
    but the sequence itself. ``mode()`` is the latest ~/mode's name and posture (None before the first), read from
    any thread."""

    def __init__(self, ask: Callable[[str, str], Awaitable[Answer]], tell: Callable[[dict[str, Any]], None],
                 mode: Callable[[], tuple[str, str] | None], *, clock: Callable[[], float] = time.monotonic,
                 sequence: Callable[..., list[StepResult]] = recover) -> None:
        self._ask = ask
        self._mode = mode
        self._tell = tell
        self._clock = clock
        self._sequence = sequence
        self._run: _Run | None = None

    def status(self) -> dict[str, Any] | None:
        """The recovery running now (who started it, the step it waits for), or None."""
        run = self._run
        return None if run is None else {"by": run.by, "step": run.step or STEPS[0],
                                         "running_s": round(self._clock() - run.started, 1)}

    def start(self, by: str) -> str | None:
        """Start a recovery for the page labelled ``by``; why not (one is running already), or None."""
        running = self.status()
        if running is not None:
            return (f"a recovery is already running (started by {running['by']}, at {running['step']}): "
                    "wait for its end, or E-STOP")
        run = self._run = _Run(by, self._clock())
        loop = asyncio.get_running_loop()
        self._tell({"event": "started", "by": by, "steps": list(STEPS)})
        threading.Thread(target=self._thread, args=(run, loop), name="recover", daemon=True).start()
        return None

    # --- the sequence's thread ------------------------------------------------------------------------
    def _thread(self, run: _Run, loop: asyncio.AbstractEventLoop) -> None:
        def post(callback: Callable[..., None], *args: Any) -> None:
            try:
                loop.call_soon_threadsafe(callback, run, *args)
            except RuntimeError:  # the loop is closed: the console has stopped, nobody to tell
                pass

        def call(service: str, argument: str) -> _Reply:
            post(self._asked, _STEP_OF.get(argument if service == "loco" else service, argument))
            answer = asyncio.run_coroutine_threadsafe(self._ask(service, argument), loop).result()
            return _Reply(bool(answer["success"]), str(answer["message"]))

        try:
            results = self._sequence(_Robot(call, self._mode), on_step=lambda result: post(self._answered, result))
        except Exception as exc:  # the console stopping cancels the step's call; anything else, the pages are told
            post(self._ended, [], f"the sequence stopped: {exc!r}")
            return
        post(self._ended, results, "")

    # --- back on the event loop -----------------------------------------------------------------------
    def _asked(self, run: _Run, step: str) -> None:
        if step == run.step:
            return
        run.step = step
        self._tell({"event": "step", "by": run.by, "step": step})

    def _answered(self, run: _Run, result: StepResult) -> None:
        self._tell({"event": "result", "by": run.by, "step": result.step, "success": result.success,
                    "message": result.message, "took_s": round(result.took_s, 2)})

    def _ended(self, run: _Run, results: list[StepResult], error: str) -> None:
        self._run = None
        failed = next((r for r in results if not r.success), None)
        success = not error and failed is None and len(results) == len(STEPS)
        if error:
            message = error
        elif failed is not None:
            message = f"failed at {failed.step}: {failed.message}"
        else:
            message = "the robot stands"
        self._tell({"event": "done", "by": run.by, "success": success, "failed_step": failed.step if failed else None,
                    "message": message, "took_s": round(self._clock() - run.started, 2)})
