"""Faults the bridge injects on demand, so tests can see how clients cope with a misbehaving robot.

Configured as JSON (ROS parameter ``faults``), e.g.::

    {"delay_s": {"1002": 5.0,    # handle and answer these api ids after a delay (others go on meanwhile)
                 "1003": [0.5, 3.0]},  # ... or after a delay drawn per request, uniform in [low, high]
     "drop": [7101],              # neither handle nor answer these api ids (the client times out: 3104)
     "error": {"7101": 3104},     # answer this code without handling the request
     "pause_state": true,         # stop publishing every state topic (the sim keeps running)
     "damp_fails": 2,             # the next 2 SetFsmId(1) answer 3104 and do not damp
     "ignore_fsm_ids": [500],     # SetFsmId of these ids answers 0 and does nothing (a firmware quirk)
     # the state estimator (rt/odommodestate; keys left out keep their defaults, firmware.odometry):
     "odom_drift": {"xy_per_m": 0.01, "xy_mps": 0.0002, "yaw_per_rad": 0.002},
     "odom_noise_m": 0.001,
     "seed": 7,                   # seed of the per-request delays (so a chaos scenario can be replayed)
     # the body, for a supervisor's checks:
     "motor_temperature": {"3": [90, 130]},   # report motor 3 at casing 90 C, winding 130 C while set
     "battery_soc": 15,           # report a 15 % charge while set
     "remote_keys": ["L2", "B"],  # these keys held on the operator's remote while set
     "push": {"force": 150, "direction": [1, 0], "duration": 0.3},  # shove the pelvis, once per setting
     "runaway_motor": {"motor": 18, "direction": 1, "duration": 0.2},  # a motor driving at its full effort, once
     "freeze_lowstate": true,     # stop rt/lowstate and rt/lf/lowstate only (everything else goes on)
     "freeze_odom": true,         # stop rt/odommodestate and rt/lf/odommodestate only (a stalled state estimator)
     # user control (sport 7110/7111, newer firmware; firmware.user_ctrl):
     "user_ctrl": "from_damp",    # the firmware option from now on (absent: sim_bridge --user-ctrl's)
     "user_ctrl_delay_s": 0.05}   # s of sim time from an accepted 7110 to fsm 1000

``ignore_fsm_ids`` is what users report of firmware 1.5.3: Start (SetFsmId 500) answers 0 from some states and
the robot stays where it was, while 501 works; a client that trusts the code believes it walks.

``odom_drift`` and ``odom_noise_m`` are not off by default: the robot's estimate is never the truth. Their
defaults are firmware.odometry's; setting them (or the seed) starts a fresh estimate from the truth.

Every key is optional; a new configuration replaces the old one as a whole. ``push`` acts once each time
a configuration holding it is set (its direction: [x, y] in the world frame, or an angle in rad from +x
towards +y; the robot boots facing +x). ``runaway_motor`` likewise: for ``duration`` s of sim time the motor puts out
its full effort limit in ``direction`` (+1 or -1) whatever it is commanded, as a motor driver that ran away would
(a flail a controller did not ask for); then it obeys its commands again.
"""

from __future__ import annotations

import json
import math
import random
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Final

from g1_mode_manager.protocol.api_ids import ERR_CLIENT_API_TIMEOUT
from g1_mode_manager.protocol.motors import NUM_JOINTS
from g1_mode_manager.protocol.remote import KEY_NAMES, UnknownKeyError, key_mask
from g1_sim.firmware import user_ctrl as user_ctrl_rules
from g1_sim.firmware.odometry import OdomErrors

#: What a failing Damp answers (the robot's controller timing out).
DAMP_FAILURE_CODE = ERR_CLIENT_API_TIMEOUT

_KEYS = frozenset({"delay_s", "drop", "error", "pause_state", "damp_fails", "seed", "motor_temperature",
                   "battery_soc", "remote_keys", "push", "runaway_motor", "freeze_lowstate", "freeze_odom",
                   "ignore_fsm_ids", "odom_drift", "odom_noise_m", "user_ctrl", "user_ctrl_delay_s"})
#: odom_drift's keys and their bounds: signed scale errors, a creep speed.
ODOM_DRIFT_BOUNDS: Final = {"xy_per_m": (-1.0, 1.0), "xy_mps": (0.0, 1.0), "yaw_per_rad": (-1.0, 1.0)}
ODOM_NOISE_MAX_M: Final = 1.0
#: Bounds of the injected values: what MotorState_'s int16 could carry sensibly, a push a person could give.
TEMPERATURE_RANGE_C: Final = (-40.0, 200.0)
PUSH_MAX_N: Final = 2000.0
PUSH_MAX_S: Final = 5.0
RUNAWAY_MAX_S: Final = 2.0


class FaultConfigError(ValueError):
    """The faults JSON is malformed; the message says what is wrong."""


@dataclass(frozen=True)
class Push:
    """A horizontal force on the pelvis: N, world-frame unit direction (x, y), seconds."""

    force_n: float
    direction: tuple[float, float]
    duration_s: float

    @property
    def force_xy(self) -> tuple[float, float]:
        return (self.force_n * self.direction[0], self.force_n * self.direction[1])

    def to_json(self) -> dict[str, Any]:
        return {"force": self.force_n, "direction": list(self.direction), "duration": self.duration_s}


@dataclass(frozen=True)
class Runaway:
    """A motor driving at its full effort limit: motor index, direction (+1 / -1), seconds."""

    motor: int
    direction: int
    duration_s: float

    def to_json(self) -> dict[str, Any]:
        return {"motor": self.motor, "direction": self.direction, "duration": self.duration_s}


@dataclass(frozen=True)
class FaultConfig:
    """One parsed faults configuration (immutable, so readers need no lock)."""

    delay_s: Mapping[int, tuple[float, float]] = field(default_factory=lambda: MappingProxyType({}))  # (low, high)
    drop: frozenset[int] = frozenset()
    error: Mapping[int, int] = field(default_factory=lambda: MappingProxyType({}))
    pause_state: bool = False
    damp_fails: int = 0
    seed: int = 0
    motor_temperature: Mapping[int, tuple[float, float]] = field(default_factory=lambda: MappingProxyType({}))  # casing, winding
    battery_soc: float | None = None
    remote_keys: frozenset[str] = frozenset()
    push: Push | None = None
    runaway_motor: Runaway | None = None
    freeze_lowstate: bool = False
    freeze_odom: bool = False
    ignore_fsm_ids: frozenset[int] = frozenset()
    odom: OdomErrors = field(default_factory=OdomErrors)
    user_ctrl: str | None = None  # None: the bridge's own option (--user-ctrl)
    user_ctrl_delay_s: float = user_ctrl_rules.DEFAULT_DELAY_S

    def to_json(self) -> dict[str, Any]:
        return {
            "delay_s": {str(k): (lo if lo == hi else [lo, hi]) for k, (lo, hi) in self.delay_s.items()},
            "drop": sorted(self.drop),
            "error": {str(k): v for k, v in self.error.items()},
            "pause_state": self.pause_state,
            "damp_fails": self.damp_fails,
            "seed": self.seed,
            "motor_temperature": {str(k): list(v) for k, v in self.motor_temperature.items()},
            "battery_soc": self.battery_soc,
            "remote_keys": sorted(self.remote_keys, key=KEY_NAMES.index),
            "push": None if self.push is None else self.push.to_json(),
            "runaway_motor": None if self.runaway_motor is None else self.runaway_motor.to_json(),
            "freeze_lowstate": self.freeze_lowstate,
            "freeze_odom": self.freeze_odom,
            "ignore_fsm_ids": sorted(self.ignore_fsm_ids),
            "odom_drift": {"xy_per_m": self.odom.xy_per_m, "xy_mps": self.odom.xy_mps,
                           "yaw_per_rad": self.odom.yaw_per_rad},
            "odom_noise_m": self.odom.noise_m,
            "user_ctrl": self.user_ctrl,
            "user_ctrl_delay_s": self.user_ctrl_delay_s,
        }


def _api_id(key: Any, where: str) -> int:
    if isinstance(key, bool):
        raise FaultConfigError(f"{where}: api id must be an integer, got {key!r}")
    try:
        api_id = int(key)
    except (TypeError, ValueError):
        raise FaultConfigError(f"{where}: api id must be an integer, got {key!r}") from None
    if api_id <= 0 or str(key).strip() != str(api_id):
        raise FaultConfigError(f"{where}: api id must be a positive integer, got {key!r}")
    return api_id


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FaultConfigError(f"{where}: expected a number, got {value!r}")
    return float(value)


def parse_faults(text: str) -> FaultConfig:
    """Parse the faults JSON ("" or "{}" = no faults); raise FaultConfigError on anything unexpected."""
    if not text.strip():
        return FaultConfig()
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as e:
        raise FaultConfigError(f"faults is not valid JSON: {e}") from None
    if not isinstance(raw, dict):
        raise FaultConfigError(f"faults must be a JSON object, got {type(raw).__name__}")
    unknown = set(raw) - _KEYS
    if unknown:
        raise FaultConfigError(f"unknown fault keys {sorted(unknown)}; known: {sorted(_KEYS)}")

    delay_raw = raw.get("delay_s", {})
    if not isinstance(delay_raw, dict):
        raise FaultConfigError("delay_s must be an object {api_id: seconds}")
    delay: dict[int, tuple[float, float]] = {}
    for k, v in delay_raw.items():
        bounds = v if isinstance(v, list) else [v, v]
        if len(bounds) != 2:
            raise FaultConfigError(f"delay_s[{k}]: expected seconds or [low, high], got {v!r}")
        low, high = (_number(b, f"delay_s[{k}]") for b in bounds)
        if not 0.0 <= low <= high <= 3600.0:
            raise FaultConfigError(f"delay_s[{k}]: seconds must be within 0..3600 and low <= high, got {v!r}")
        delay[_api_id(k, "delay_s")] = (low, high)

    drop_raw = raw.get("drop", [])
    if not isinstance(drop_raw, list):
        raise FaultConfigError("drop must be a list of api ids")
    drop = frozenset(_api_id(k, "drop") for k in drop_raw)

    error_raw = raw.get("error", {})
    if not isinstance(error_raw, dict):
        raise FaultConfigError("error must be an object {api_id: code}")
    error: dict[int, int] = {}
    for k, v in error_raw.items():
        code = _number(v, f"error[{k}]")
        if code != int(code) or code == 0:
            raise FaultConfigError(f"error[{k}]: code must be a non-zero integer, got {v!r}")
        error[_api_id(k, "error")] = int(code)

    pause = raw.get("pause_state", False)
    if not isinstance(pause, bool):
        raise FaultConfigError(f"pause_state must be true or false, got {pause!r}")

    damp_fails = raw.get("damp_fails", 0)
    if isinstance(damp_fails, bool) or not isinstance(damp_fails, int) or damp_fails < 0:
        raise FaultConfigError(f"damp_fails must be a non-negative integer, got {damp_fails!r}")

    seed = raw.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise FaultConfigError(f"seed must be an integer, got {seed!r}")

    freeze = raw.get("freeze_lowstate", False)
    if not isinstance(freeze, bool):
        raise FaultConfigError(f"freeze_lowstate must be true or false, got {freeze!r}")
    freeze_odom = raw.get("freeze_odom", False)
    if not isinstance(freeze_odom, bool):
        raise FaultConfigError(f"freeze_odom must be true or false, got {freeze_odom!r}")

    return FaultConfig(MappingProxyType(delay), drop, MappingProxyType(error), pause, damp_fails, seed,
                       motor_temperature=MappingProxyType(_motor_temperature(raw.get("motor_temperature", {}))),
                       battery_soc=_battery_soc(raw.get("battery_soc")), remote_keys=_remote_keys(raw.get("remote_keys", [])),
                       push=_push(raw.get("push")), runaway_motor=_runaway(raw.get("runaway_motor")),
                       freeze_lowstate=freeze, freeze_odom=freeze_odom,
                       ignore_fsm_ids=_fsm_ids(raw.get("ignore_fsm_ids", []), "ignore_fsm_ids"),
                       odom=_odom(raw.get("odom_drift", {}), raw.get("odom_noise_m")),
                       user_ctrl=_user_ctrl_option(raw.get("user_ctrl")),
                       user_ctrl_delay_s=_user_ctrl_delay(raw.get("user_ctrl_delay_s")))


def _user_ctrl_option(raw: Any) -> str | None:
    if raw is None:
        return None
    if not isinstance(raw, str):
        raise FaultConfigError(f"user_ctrl must be one of {[o.value for o in user_ctrl_rules.UserCtrlOption]}, got {raw!r}")
    try:
        return user_ctrl_rules.parse_option(raw).value
    except ValueError as e:
        raise FaultConfigError(str(e)) from None


def _user_ctrl_delay(raw: Any) -> float:
    if raw is None:
        return user_ctrl_rules.DEFAULT_DELAY_S
    try:
        return user_ctrl_rules.check_delay(raw)
    except ValueError as e:
        raise FaultConfigError(str(e)) from None


def _fsm_ids(raw: Any, where: str) -> frozenset[int]:
    if not isinstance(raw, list):
        raise FaultConfigError(f"{where} must be a list of fsm ids (integers >= 0, e.g. [500]), got {raw!r}")
    for v in raw:
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise FaultConfigError(f"{where}: an fsm id must be an integer >= 0, got {v!r}")
    return frozenset(raw)


def _odom(drift: Any, noise: Any) -> OdomErrors:
    if not isinstance(drift, dict):
        raise FaultConfigError(f"odom_drift must be an object {{{', '.join(ODOM_DRIFT_BOUNDS)}}}, got {drift!r}")
    unknown = set(drift) - set(ODOM_DRIFT_BOUNDS)
    if unknown:
        raise FaultConfigError(f"odom_drift: unknown keys {sorted(unknown)}; known: {list(ODOM_DRIFT_BOUNDS)}")
    values: dict[str, float] = {}
    for key, (low, high) in ODOM_DRIFT_BOUNDS.items():
        if key in drift:
            values[key] = _number(drift[key], f"odom_drift.{key}")
            if not low <= values[key] <= high:
                raise FaultConfigError(f"odom_drift.{key} must be within {low:g}..{high:g}, got {drift[key]!r}")
    if noise is not None:
        values["noise_m"] = _number(noise, "odom_noise_m")
        if not 0.0 <= values["noise_m"] <= ODOM_NOISE_MAX_M:
            raise FaultConfigError(f"odom_noise_m must be within 0..{ODOM_NOISE_MAX_M:g} m, got {noise!r}")
    return OdomErrors(**values)


def _motor_temperature(raw: Any) -> dict[int, tuple[float, float]]:
    if not isinstance(raw, dict):
        raise FaultConfigError('motor_temperature must be an object {"motor index": [casing, winding]}')
    out: dict[int, tuple[float, float]] = {}
    low, high = TEMPERATURE_RANGE_C
    for k, v in raw.items():
        try:
            index = int(k)
        except (TypeError, ValueError):
            index = -1
        if not 0 <= index < NUM_JOINTS or str(k).strip() != str(index):
            raise FaultConfigError(f"motor_temperature: motor index must be 0..{NUM_JOINTS - 1}, got {k!r}")
        if not isinstance(v, list) or len(v) != 2:
            raise FaultConfigError(f"motor_temperature[{k}]: expected [casing, winding] in deg C, got {v!r}")
        casing, winding = (_number(t, f"motor_temperature[{k}]") for t in v)
        if not (low <= casing <= high and low <= winding <= high):
            raise FaultConfigError(f"motor_temperature[{k}]: deg C must be within {low:g}..{high:g}, got {v!r}")
        out[index] = (casing, winding)
    return out


def _battery_soc(raw: Any) -> float | None:
    if raw is None:
        return None
    soc = _number(raw, "battery_soc")
    if not 0.0 <= soc <= 100.0:
        raise FaultConfigError(f"battery_soc must be a percentage 0..100, got {raw!r}")
    return soc


def _remote_keys(raw: Any) -> frozenset[str]:
    if not isinstance(raw, list) or not all(isinstance(k, str) for k in raw):
        raise FaultConfigError(f"remote_keys must be a list of key names ({', '.join(KEY_NAMES)}), got {raw!r}")
    try:
        key_mask(raw)
    except UnknownKeyError as e:
        raise FaultConfigError(f"remote_keys: {e}") from None
    return frozenset(raw)


def _push(raw: Any) -> Push | None:
    if raw is None:
        return None
    if not isinstance(raw, dict) or set(raw) != {"force", "direction", "duration"}:
        raise FaultConfigError(f'push must be an object {{"force": N, "direction": [x, y] or rad, "duration": s}}, '
                               f"got {raw!r}")
    force = _number(raw["force"], "push.force")
    if not 0.0 < force <= PUSH_MAX_N:
        raise FaultConfigError(f"push.force must be within 0..{PUSH_MAX_N:g} N (not 0), got {raw['force']!r}")
    duration = _number(raw["duration"], "push.duration")
    if not 0.0 < duration <= PUSH_MAX_S:
        raise FaultConfigError(f"push.duration must be within 0..{PUSH_MAX_S:g} s (not 0), got {raw['duration']!r}")
    direction = raw["direction"]
    if isinstance(direction, list):
        if len(direction) != 2:
            raise FaultConfigError(f"push.direction must be [x, y] or an angle in rad, got {direction!r}")
        x, y = (_number(d, "push.direction") for d in direction)
    else:
        angle = _number(direction, "push.direction")
        x, y = math.cos(angle), math.sin(angle)
    norm = math.hypot(x, y)
    if not norm > 1e-9 or not math.isfinite(norm):
        raise FaultConfigError(f"push.direction must not be zero, got {direction!r}")
    return Push(force, (x / norm, y / norm), duration)


def _runaway(raw: Any) -> Runaway | None:
    if raw is None:
        return None
    if not isinstance(raw, dict) or not {"motor", "duration"} <= set(raw) <= {"motor", "direction", "duration"}:
        raise FaultConfigError(f'runaway_motor must be an object {{"motor": index, "direction": 1 or -1, "duration": s}}, '
                               f"got {raw!r}")
    motor, direction = raw["motor"], raw.get("direction", 1)
    if isinstance(motor, bool) or not isinstance(motor, int) or not 0 <= motor < NUM_JOINTS:
        raise FaultConfigError(f"runaway_motor.motor must be a motor index 0..{NUM_JOINTS - 1}, got {motor!r}")
    if direction not in (1, -1) or isinstance(direction, bool):
        raise FaultConfigError(f"runaway_motor.direction must be 1 or -1, got {direction!r}")
    duration = _number(raw["duration"], "runaway_motor.duration")
    if not 0.0 < duration <= RUNAWAY_MAX_S:
        raise FaultConfigError(f"runaway_motor.duration must be within 0..{RUNAWAY_MAX_S:g} s (not 0), got "
                               f"{raw['duration']!r}")
    return Runaway(motor, direction, duration)


class Faults:
    """The active fault configuration, shared by the RPC servers and the state publishers.

    ``on_change(old, new)`` is called after every ``set`` (the bridge hands the body's injections to the
    robot and records them).

    The sim thread decides and publishes a step's samples inside ``held()``, and ``set`` swaps the configuration
    only between two such steps: once ``set`` returns, no sample goes out that was decided under the old one (a
    frozen stream's count stops at the answer to the parameter call, not one sample later).
    """

    def __init__(self, config: FaultConfig | None = None) -> None:
        self._lock = threading.Lock()
        self._step = threading.Lock()
        self._config = config or FaultConfig()
        self._damp_fails_left = self._config.damp_fails
        self._rng = random.Random(self._config.seed)
        self.on_change: Callable[[FaultConfig, FaultConfig], None] | None = None

    @property
    def config(self) -> FaultConfig:
        return self._config

    def set(self, config: FaultConfig) -> None:
        """Replace the configuration. The damp failure budget restarts from config.damp_fails only when that
        number changes: a body injection or a re-sent configuration does not make the next Damps fail again (a
        robot whose Damps failed twice does not fail twice more because a motor heated up meanwhile)."""
        with self._step, self._lock:
            old, self._config = self._config, config
            if config.damp_fails != old.damp_fails:
                self._damp_fails_left = config.damp_fails
            self._rng = random.Random(config.seed)
        if self.on_change is not None:
            self.on_change(old, config)

    def held(self) -> threading.Lock:
        """Held by the sim thread while it publishes one step's samples (``set`` waits for the step's end)."""
        return self._step

    def set_json(self, text: str) -> FaultConfig:
        """Parse and apply; on error raise FaultConfigError and keep the previous configuration."""
        config = parse_faults(text)
        self.set(config)
        return config

    def delay_s(self, api_id: int) -> float:
        """This request's delay: fixed, or drawn from [low, high] (the robot's seconds vary per call)."""
        low, high = self._config.delay_s.get(api_id, (0.0, 0.0))
        if low == high:
            return low
        with self._lock:
            return self._rng.uniform(low, high)

    def drops(self, api_id: int) -> bool:
        return api_id in self._config.drop

    def error_code(self, api_id: int) -> int | None:
        return self._config.error.get(api_id)

    def ignores_fsm(self, fsm_id: int) -> bool:
        """SetFsmId(fsm_id) must answer 0 and do nothing."""
        return fsm_id in self._config.ignore_fsm_ids

    @property
    def state_paused(self) -> bool:
        return self._config.pause_state

    @property
    def lowstate_frozen(self) -> bool:
        return self._config.freeze_lowstate

    @property
    def odom_frozen(self) -> bool:
        return self._config.freeze_odom

    def take_damp_failure(self) -> bool:
        """True (and one failure used up) if this Damp must fail."""
        with self._lock:
            if self._damp_fails_left > 0:
                self._damp_fails_left -= 1
                return True
            return False

    @property
    def damp_fails_left(self) -> int:
        with self._lock:
            return self._damp_fails_left
