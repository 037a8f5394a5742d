"""The G1's RPC services (sport, motion_switcher, arm) served with the SDK's own Server class.

Handlers are pure functions of a robot object (``SimG1`` or a stand-in in unit tests) and the JSON
parameter. ``SimServer`` is the SDK's ``Server`` with two additions the robot does not have: every
request is counted per api id, and faults (delay, drop, error) apply before the SDK's dispatch, so
unknown ids (3203), the api version query and handler exceptions (3202) behave exactly as the SDK's.

Decisions where the robot's behaviour is not documented:

* While the motion switcher has released the service (debug mode), every sport api answers 3203
  (api not implemented) at once, getters included, and nothing acts. (The robot may also not answer
  at all; a prompt 3203 keeps tests fast, and clients treat both as "service inactive".)
* A malformed parameter (not JSON, missing or mistyped field) answers 3204 and nothing acts.
* Fault ``ignore_fsm_ids``: SetFsmId of those ids answers 0 and nothing changes (the firmware quirk users
  report for Start); counted and recorded like any handled request.
* SwitchToUserCtrl (7110) and SwitchToInternalCtrl (7111): the robot's (firmware.user_ctrl) decides, 3203
  included where the firmware option is ``none``; 7110's parameter is not looked at (the SDK sends
  ``{"data": false}``), 7111's ``data`` must be 0, 1 or 2 (else 3204).
* Fault ``error``: answered with the given code, not handled. ``drop``: neither handled nor
  answered. ``delay_s``: handled and answered after the delay, in a timer thread, so requests to
  other api ids are served meanwhile.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from typing import Any, Protocol

from unitree_sdk2py.rpc.server import Server

from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.unitree_sdk_internals import (
    channel_datareader,
    server_handler,
    server_request_channel,
    server_request_handler,
)
from g1_sim.bridge.arrivals import Arrivals, request_id
from g1_sim.bridge.faults import DAMP_FAILURE_CODE, Faults

Reply = tuple[int, str]
Handler = Callable[[str], Reply]


class SportRobot(Protocol):
    """What the sport and motion switcher handlers need from the simulated robot."""

    def sport_active(self) -> bool: ...
    def set_fsm_id(self, fsm_id: int) -> int: ...
    def get_fsm_id(self) -> tuple[int, int]: ...
    def get_fsm_mode(self) -> tuple[int, int]: ...
    def set_balance_mode(self, mode: int) -> int: ...
    def get_balance_mode(self) -> tuple[int, int]: ...
    def set_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> int: ...
    def set_speed_mode(self, mode: int) -> int: ...
    def set_arm_task(self, task_id: int) -> int: ...
    def set_stand_height(self, height: float) -> int: ...
    def get_stand_height(self) -> tuple[int, float]: ...
    def set_swing_height(self, height: float) -> int: ...
    def get_swing_height(self) -> tuple[int, float]: ...
    def check_mode(self) -> tuple[str, str]: ...
    def select_mode(self, name: str) -> int: ...
    def release_mode(self) -> int: ...
    def get_silent(self) -> Any: ...
    def set_silent(self, silent: bool) -> int: ...
    def switch_to_user_ctrl(self) -> int: ...
    def switch_to_internal_ctrl(self, target: int) -> int: ...


class BadParameterError(ValueError):
    """The request's JSON parameter is malformed (answered 3204)."""


def _params(parameter: str) -> dict[str, Any]:
    try:
        value = json.loads(parameter) if parameter.strip() else {}
    except json.JSONDecodeError as e:
        raise BadParameterError(f"not JSON: {e}") from None
    if not isinstance(value, dict):
        raise BadParameterError("parameter must be a JSON object")
    return value


def _number(params: dict[str, Any], key: str) -> float:
    value = params.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise BadParameterError(f"{key!r} must be a finite number, got {value!r}")
    return float(value)


def _integer(params: dict[str, Any], key: str) -> int:
    value = _number(params, key)
    if value != int(value):
        raise BadParameterError(f"{key!r} must be an integer, got {value!r}")
    return int(value)


def _data_reply(result: tuple[int, Any]) -> Reply:
    code, value = result
    return (code, json.dumps({"data": value}) if code == api.OK else "")


def _guarded(handler: Callable[[dict[str, Any]], Reply]) -> Handler:
    """Parse the JSON parameter; a malformed one answers 3204."""

    def run(parameter: str) -> Reply:
        try:
            return handler(_params(parameter))
        except BadParameterError:
            return (api.ERR_SERVER_API_PARAMETER, "")

    return run


def sport_handlers(robot: SportRobot, faults: Faults) -> dict[int, Handler]:
    """Handlers of the sport service by api id (GetPhase: 3203)."""

    def set_fsm_id(p: dict[str, Any]) -> Reply:
        fsm_id = _integer(p, "data")
        if fsm_id == 1 and faults.take_damp_failure():
            return (DAMP_FAILURE_CODE, "")
        if faults.ignores_fsm(fsm_id):
            return (api.OK, "")
        return (robot.set_fsm_id(fsm_id), "")

    def set_velocity(p: dict[str, Any]) -> Reply:
        velocity = p.get("velocity")
        if not isinstance(velocity, list) or len(velocity) != 3:
            raise BadParameterError(f"'velocity' must be [vx, vy, wz], got {velocity!r}")
        vx, vy, wz = (_number({"v": v}, "v") for v in velocity)
        duration = _number(p, "duration") if "duration" in p else api.MOVE_DURATION_S
        if duration < 0:
            raise BadParameterError(f"'duration' must be >= 0, got {duration}")
        return (robot.set_velocity(vx, vy, wz, duration), "")

    table: dict[int, Callable[[dict[str, Any]], Reply]] = {
        api.LOCO_GET_FSM_ID: lambda p: _data_reply(robot.get_fsm_id()),
        api.LOCO_GET_FSM_MODE: lambda p: _data_reply(robot.get_fsm_mode()),
        api.LOCO_GET_BALANCE_MODE: lambda p: _data_reply(robot.get_balance_mode()),
        api.LOCO_GET_SWING_HEIGHT: lambda p: _data_reply(robot.get_swing_height()),
        api.LOCO_GET_STAND_HEIGHT: lambda p: _data_reply(robot.get_stand_height()),
        api.LOCO_SET_FSM_ID: set_fsm_id,
        api.LOCO_SET_BALANCE_MODE: lambda p: (robot.set_balance_mode(_integer(p, "data")), ""),
        api.LOCO_SET_SWING_HEIGHT: lambda p: (robot.set_swing_height(_number(p, "data")), ""),
        api.LOCO_SET_STAND_HEIGHT: lambda p: (robot.set_stand_height(_number(p, "data")), ""),
        api.LOCO_SET_VELOCITY: set_velocity,
        api.LOCO_SET_SPEED_MODE: lambda p: (robot.set_speed_mode(_integer(p, "data")), ""),
        api.LOCO_SET_ARM_TASK: lambda p: (robot.set_arm_task(_integer(p, "data")), ""),
        api.LOCO_SWITCH_TO_USER_CTRL: lambda p: (robot.switch_to_user_ctrl(), ""),
        api.LOCO_SWITCH_TO_INTERNAL_CTRL: lambda p: (robot.switch_to_internal_ctrl(_integer(p, "data")), ""),
    }

    def only_while_active(handler: Handler) -> Handler:
        def run(parameter: str) -> Reply:
            if not robot.sport_active():
                return (api.ERR_SERVER_API_NOT_IMPL, "")
            return handler(parameter)

        return run

    return {api_id: only_while_active(_guarded(h)) for api_id, h in table.items()}


def motion_switcher_handlers(robot: SportRobot) -> dict[int, Handler]:
    """Handlers of the motion_switcher service by api id."""

    def check_mode(p: dict[str, Any]) -> Reply:
        form, name = robot.check_mode()
        return (api.OK, json.dumps({"form": str(form), "name": name}))

    def select_mode(p: dict[str, Any]) -> Reply:
        name = p.get("name")
        if not isinstance(name, str):
            raise BadParameterError(f"'name' must be a string, got {name!r}")
        return (robot.select_mode(name), "")

    def set_silent(p: dict[str, Any]) -> Reply:
        silent = p.get("silent")
        if not isinstance(silent, bool):
            raise BadParameterError(f"'silent' must be true or false, got {silent!r}")
        return (robot.set_silent(silent), "")

    def get_silent(p: dict[str, Any]) -> Reply:
        result = robot.get_silent()
        code, silent = result if isinstance(result, tuple) else (api.OK, result)
        return (code, json.dumps({"silent": bool(silent)}) if code == api.OK else "")

    table: dict[int, Callable[[dict[str, Any]], Reply]] = {
        api.MS_CHECK_MODE: check_mode,
        api.MS_SELECT_MODE: select_mode,
        api.MS_RELEASE_MODE: lambda p: (robot.release_mode(), ""),
        api.MS_SET_SILENT: set_silent,
        api.MS_GET_SILENT: get_silent,
    }
    return {api_id: _guarded(h) for api_id, h in table.items()}


class ArmRobot(Protocol):
    """What the arm action service needs from the simulated robot."""

    def execute_arm_action(self, action_id: int) -> int: ...
    def arm_action_list(self) -> dict[int, str]: ...


def arm_action_handlers(robot: ArmRobot) -> dict[int, Handler]:
    """Handlers of the ``arm`` service: ExecuteAction {"data": id} as the Python SDK sends it, or
    {"action_id": id} as the C++ SDK does; GetActionList answers ``[{"id", "name"}, ...]`` (the robot's reply
    format is not documented). The sim has no actions taught with Unitree's app: ExecuteCustomAction answers
    7402 (the SDK's "Invalid action id.") for any name, StopCustomAction 0 (nothing plays)."""

    def execute(p: dict[str, Any]) -> Reply:
        return (robot.execute_arm_action(_integer(p, "data" if "data" in p else "action_id")), "")

    def execute_custom(p: dict[str, Any]) -> Reply:
        if not isinstance(p.get("action_name"), str):
            raise BadParameterError(f"'action_name' must be a string, got {p.get('action_name')!r}")
        return (api.ARM_ERR_INVALID_ACTION_ID, "")

    def action_list(p: dict[str, Any]) -> Reply:
        actions = [{"id": i, "name": n} for i, n in sorted(robot.arm_action_list().items())]
        return (api.OK, json.dumps(actions))

    table: dict[int, Callable[[dict[str, Any]], Reply]] = {
        api.ARM_EXECUTE_ACTION: execute,
        api.ARM_GET_ACTION_LIST: action_list,
        api.ARM_EXECUTE_CUSTOM_ACTION: execute_custom,
        api.ARM_STOP_CUSTOM_ACTION: lambda p: (api.OK, ""),
    }
    return {api_id: _guarded(h) for api_id, h in table.items()}


class RequestCounter:
    """Requests received per service and api id, and the last one of each (thread-safe).

    Receive times are CLOCK_MONOTONIC, which every process of the machine shares,
    so a benchmark can compare it with the time it sent the request.
    """

    RECENT = 16

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._counts: dict[str, Counter[int]] = {}
        self._recent: dict[str, dict[int, deque[dict[str, Any]]]] = {}

    def add(self, service: str, api_id: int, parameter: str = "") -> None:
        now = time.monotonic()
        with self._lock:
            self._counts.setdefault(service, Counter())[api_id] += 1
            recent = self._recent.setdefault(service, {}).setdefault(api_id, deque(maxlen=self.RECENT))
            recent.append({"t": now, "parameter": parameter[:200]})

    def snapshot(self) -> dict[str, dict[str, int]]:
        with self._lock:
            return {s: {str(k): v for k, v in sorted(c.items())} for s, c in self._counts.items()}

    def recent(self) -> dict[str, dict[str, list[dict[str, Any]]]]:
        """The last RECENT requests of each api id, oldest first."""
        with self._lock:
            return {s: {str(k): [dict(r) for r in v] for k, v in sorted(c.items())} for s, c in self._recent.items()}


#: on_received(service, api_id, parameter, noreply, receive time, identity id) when a request arrives (the time
#: Cyclone delivered it, see arrivals.py, or None: now; the id as the client wrote it); on_handled(service,
#: api_id, parameter, code) once it was handled (after any injected delay). For the sim's record.
Received = Callable[[str, int, str, bool, float | None, int], None]
Handled = Callable[[str, int, str, int], None]


class SimServer(Server):
    """The SDK's RPC Server plus request counting, injected faults and hooks for the sim's record."""

    def __init__(self, name: str, version: str, handlers: dict[int, Handler], *,
                 faults: Faults | None = None, counter: RequestCounter | None = None,
                 on_received: Received | None = None, on_handled: Handled | None = None) -> None:
        super().__init__(name)
        self._faults = faults or Faults()
        self._counter = counter or RequestCounter()
        self._on_received = on_received
        self._on_handled = on_handled
        self._timers: list[threading.Timer] = []
        self._timers_lock = threading.Lock()
        self._arrivals: Arrivals | None = None
        self._SetApiVersion(version)
        for api_id, handler in handlers.items():
            self._RegistHandler(api_id, self._with_error_fault(api_id, handler), False)

    def _with_error_fault(self, api_id: int, handler: Handler) -> Handler:
        def run(parameter: str) -> Reply:
            code = self._faults.error_code(api_id)
            reply = (code, "") if code is not None else handler(parameter)
            if self._on_handled is not None:
                self._on_handled(self.GetName(), api_id, parameter, reply[0])
            return reply

        return run

    def Start(self, enable_prio_queue: bool = False) -> None:
        # The SDK's Server.Start installs its private dispatcher; ours wraps it (faults, counting).
        self._SetServerRequestHandler(self._on_request)
        self._Start(enable_prio_queue)
        if self._on_received is not None:  # the record wants receive times: stamp where Cyclone delivers
            self._arrivals = Arrivals(channel_datareader(server_request_channel(self)), request_id, window=32)

    def _dispatch(self, request: Any) -> None:
        server_request_handler(self)(request)

    def _on_request(self, request: Any) -> None:
        api_id = int(request.header.identity.api_id)
        self._counter.add(self.GetName(), api_id, str(request.parameter))
        if self._on_received is not None:
            request_id = int(request.header.identity.id)
            t = self._arrivals.pop(request_id) if self._arrivals is not None else None
            self._on_received(self.GetName(), api_id, str(request.parameter), bool(request.header.policy.noreply), t,
                              request_id)
        if self._faults.drops(api_id):
            return
        delay = self._faults.delay_s(api_id)
        if delay > 0:
            timer = threading.Timer(delay, self._dispatch, (request,))
            timer.daemon = True
            with self._timers_lock:
                self._timers = [t for t in self._timers if t.is_alive()]
                self._timers.append(timer)
            timer.start()
            return
        self._dispatch(request)

    def cancel_delayed(self) -> None:
        """Forget delayed requests (at shutdown)."""
        with self._timers_lock:
            for t in self._timers:
                t.cancel()
            self._timers.clear()

    def handle_for_test(self, api_id: int, parameter: str) -> Reply:
        """Run a registered handler directly (unit tests without DDS)."""
        handler, _ = server_handler(self, api_id)
        if handler is None:
            return (api.ERR_SERVER_API_NOT_IMPL, "")
        return handler(parameter)
