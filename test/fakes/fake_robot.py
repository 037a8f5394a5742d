"""A fake G1 behind the ModePort: the motion switcher's service state, a call log, and injectable faults.

It behaves like the robot where it matters for the mode machine: SelectMode makes a service active
(the robot comes back limp), ReleaseMode releases it (possibly only after several calls), Damp
answers only while a service is active (3203 otherwise), and every call before connect() fails
with a send error. Every call is logged on entry with the service state at that moment and the
calling thread, so tests can check what reached the robot in which state.
"""

from __future__ import annotations

import threading
import time
from collections import defaultdict, deque
from collections.abc import Callable
from dataclasses import dataclass

from g1_mode_manager.core.port import RobotError
from g1_mode_manager.protocol import api_ids

ACTIVE = api_ids.HIGH_LEVEL_SERVICE_NAME
RELEASED = ""

CALL_NAMES = ("connect", "check_mode", "select_mode", "release_mode", "damp", "damp_no_reply", "get_fsm_id",
              "switch_to_user_ctrl", "switch_to_internal_ctrl")  # the last two: fakes.fake_user_ctrl


@dataclass
class Call:
    """One call as the robot saw it: logged on entry, result filled in on exit."""

    name: str
    args: tuple[object, ...]
    service: str  # the truly active service when the call arrived
    thread: str
    result: str = "pending"  # "ok", or the error text

    @property
    def ok(self) -> bool:
        return self.result == "ok"


class Hold:
    """Keeps the next call of one name blocked inside the robot until released."""

    def __init__(self, name: str, timeout_s: float) -> None:
        self.name = name
        self.timeout_s = timeout_s
        self.entered = threading.Event()
        self._released = threading.Event()

    def release(self) -> None:
        self._released.set()

    def wait_entered(self, timeout_s: float = 5.0) -> bool:
        return self.entered.wait(timeout_s)

    def _block(self) -> None:
        self.entered.set()
        if not self._released.wait(self.timeout_s):  # a forgotten hold must not hang the test run
            raise RobotError(self.name, api_ids.ERR_CLIENT_API_TIMEOUT, "held call never released")


class FakeRobot:
    """ModePort fake. Faults apply to the next call(s) of a name, in the order they were queued."""

    def __init__(self, service: str = ACTIVE, *, release_attempts: int = 1) -> None:
        self._lock = threading.Lock()
        self._service = service
        self._calls: list[Call] = []
        self._faults: dict[str, deque[BaseException]] = defaultdict(deque)
        self._holds: dict[str, deque[Hold]] = defaultdict(deque)
        self._check_lies = 0
        self._check_lag = 0
        self._stale: deque[str] = deque()
        self.connected = False
        self.damped = False  # the robot is damping (fsm 1) right now
        #: ReleaseMode calls needed before the service is released (per release episode)
        self.release_attempts = release_attempts
        self._release_count = 0
        #: ReleaseMode answers ok but the service stays active
        self.release_never_works = False
        #: SelectMode answers ok but no service becomes active
        self.select_never_works = False
        #: real seconds a call takes inside the robot before its effect (for races between threads):
        #: a number for every call, or a function of the call's name (latencies that differ per call)
        self.latency_s: float | Callable[[str], float] = 0.0

    # --- fault injection ---------------------------------------------------------------------------
    def fail(self, name: str, code: int = api_ids.ERR_CLIENT_API_TIMEOUT, times: int = 1) -> None:
        """The next ``times`` calls of ``name`` raise RobotError(code) without taking effect."""
        self._check_name(name)
        with self._lock:
            self._faults[name].extend(RobotError(name, code, "injected") for _ in range(times))

    def crash(self, name: str, exc: BaseException, times: int = 1) -> None:
        """The next ``times`` calls of ``name`` raise ``exc`` (not a RobotError) without effect."""
        self._check_name(name)
        with self._lock:
            self._faults[name].extend(exc for _ in range(times))

    def hold(self, name: str, timeout_s: float = 10.0) -> Hold:
        """Block the next call of ``name`` (after logging it, before its effect) until released."""
        self._check_name(name)
        hold = Hold(name, timeout_s)
        with self._lock:
            self._holds[name].append(hold)
        return hold

    def lie_check(self, times: int) -> None:
        """The next ``times`` CheckMode answers report the opposite of the truth."""
        with self._lock:
            self._check_lies += times

    def lag_check(self, times: int) -> None:
        """After each service change from now on, CheckMode reports the old service ``times`` more times."""
        with self._lock:
            self._check_lag = times

    def set_service(self, name: str) -> None:
        """Change the active service behind the machine's back (an app, a reboot)."""
        with self._lock:
            self._service = name

    def clear_faults(self) -> None:
        with self._lock:
            self._faults.clear()
            self._check_lies = 0
            self._check_lag = 0
            self._stale.clear()
            self.release_never_works = False
            self.select_never_works = False
            self.release_attempts = 1

    @property
    def has_faults(self) -> bool:
        with self._lock:
            return bool(
                any(self._faults.values())
                or self._check_lies
                or self._check_lag
                or self._stale
                or self.release_never_works
                or self.select_never_works
                or self.release_attempts > 1
            )

    # --- what happened -------------------------------------------------------------------------------
    @property
    def service(self) -> str:
        with self._lock:
            return self._service

    @property
    def calls(self) -> list[Call]:
        with self._lock:
            return list(self._calls)

    def names(self, since: int = 0) -> list[str]:
        return [c.name for c in self.calls[since:]]

    # --- ModePort ------------------------------------------------------------------------------------
    def connect(self) -> None:
        self._enter("connect", ())
        with self._lock:
            self.connected = True

    def check_mode(self, timeout_s: float | None = None) -> str:
        self._enter("check_mode", ())
        with self._lock:
            name = self._stale.popleft() if self._stale else self._service
            if self._check_lies > 0:
                self._check_lies -= 1
                name = RELEASED if name else ACTIVE
            return name

    def select_mode(self, name: str, timeout_s: float | None = None) -> None:
        self._enter("select_mode", (name,))
        with self._lock:
            if not self.select_never_works and self._service != name:
                self._change_service(name)
                self.damped = False  # the robot comes back in zero torque
            self._release_count = 0

    def release_mode(self, timeout_s: float | None = None) -> None:
        self._enter("release_mode", ())
        with self._lock:
            self._release_count += 1
            if not self.release_never_works and self._release_count >= self.release_attempts:
                if self._service:
                    self._change_service(RELEASED)
                self.damped = False
                self._release_count = 0

    def damp(self, timeout_s: float | None = None) -> None:
        call = self._enter("damp", ())
        with self._lock:
            if not self._service:
                error = RobotError("damp", api_ids.ERR_SERVER_API_NOT_IMPL, "sport service released")
                call.result = str(error)
                raise error
            self.damped = True

    def damp_no_reply(self) -> None:
        self._enter("damp_no_reply", ())
        with self._lock:
            if self._service:  # in debug mode nobody listens; the request is lost without a word
                self.damped = True

    def get_fsm_id(self, timeout_s: float | None = None) -> int:
        """1 while damping, else 4 (standing); 3203 in debug mode, as the sport service answers then."""
        call = self._enter("get_fsm_id", ())
        with self._lock:
            if not self._service:
                error = RobotError("get_fsm_id", api_ids.ERR_SERVER_API_NOT_IMPL, "sport service released")
                call.result = str(error)
                raise error
            return 1 if self.damped else 4

    def undamp(self) -> None:
        """Another program takes the robot out of damping (e.g. SetFsmId(4)) behind the machine's back."""
        with self._lock:
            self.damped = False

    # --- internals -----------------------------------------------------------------------------------
    def _change_service(self, name: str) -> None:
        """Caller holds the lock."""
        self._stale = deque([self._service] * self._check_lag)
        self._service = name

    def _enter(self, name: str, args: tuple[object, ...]) -> Call:
        """Log the call, block if held, raise an injected fault or a not-connected error."""
        with self._lock:
            call = Call(name, args, self._service, threading.current_thread().name)
            self._calls.append(call)
            hold = self._holds[name].popleft() if self._holds[name] else None
        if hold is not None:
            try:
                hold._block()
            except RobotError as exc:
                call.result = str(exc)
                raise
        latency = self.latency_s(name) if callable(self.latency_s) else self.latency_s
        if latency:
            time.sleep(latency)
        with self._lock:
            fault = self._faults[name].popleft() if self._faults[name] else None
            if fault is None and not self.connected and name != "connect":
                fault = RobotError(name, api_ids.ERR_CLIENT_SEND, "not connected")
        if fault is not None:
            call.result = str(fault) or type(fault).__name__
            raise fault
        call.result = "ok"
        return call

    @staticmethod
    def _check_name(name: str) -> None:
        if name not in CALL_NAMES:
            raise ValueError(f"unknown call {name!r}; calls: {', '.join(CALL_NAMES)}")
