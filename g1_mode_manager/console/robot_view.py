"""The console's picture of the robot, from what the mode manager publishes: ``~/mode``, ``/diagnostics``
(link, body checks, Moves acknowledged), ``odom`` and ``~/imu``. Pure: the bridge hands in plain values with
the time they arrived, the server asks for a snapshot (JSON-ready) and a plot sample.

Where each plotted value comes from, and at what rate:
* commanded: the velocity this console publishes on cmd_vel (its publish rate; 0 while it publishes nothing);
* acknowledged: the last Move the robot acknowledged, from /diagnostics (``walking`` commanded_mps, counted only
  if ``moves_sent`` grew since the previous message): diagnostics_rate_hz, 1 Hz by default;
* measured: the robot's own odometry (``odom``, twist), odom_rate_hz (20 Hz in the launch files; none when off);
* autonomy: the planner's latest command after the node's clamp, from /diagnostics (``driver`` autonomy_vx,
  autonomy_vy) while the autonomy drives, suspended or not: diagnostics_rate_hz; a gap while it does not drive;
* tilt: the pelvis IMU (``~/imu``, when joint states are on), else the odometry's attitude, else the body check's
  value in /diagnostics; all three are the angle between the body's z axis and vertical.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from g1_mode_manager.core.body.readings import tilt_of
from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.display.head_led import LedLook

#: ~/mode is published on every change and at mode_publish_rate_hz (1 Hz): older than this, the node is silent.
MODE_SILENT_S = 3.0
#: A stream older than these no longer feeds the plots (s).
FAST_STALE_S = 0.5
DIAGNOSTICS_STALE_S = 3.0
#: The key of the head LED's look in HIGH_LEVEL while the autonomy drives (beside the modes' names).
AUTONOMY_LOOK = "autonomy"
#: Body checks the head shows, and the check whose value each one is.
BODY_SUMMARY = {"battery_pct": "battery_low", "winding_max_c": "winding_overheat", "casing_max_c": "casing_overheat",
                "tilt_rad": "tilt"}


@dataclass(frozen=True)
class DiagStatus:
    name: str
    level: int
    message: str
    values: dict[str, str]


@dataclass
class Stamped:
    """A value with the time it arrived: stale after a while, so a silent source shows as a gap, not a value."""

    value: Any = None
    at: float = -math.inf

    def fresh(self, now: float, within_s: float) -> Any:
        return self.value if now - self.at <= within_s else None


def _number(text: str | None) -> float | None:
    try:
        value = float(text) if text else None
    except ValueError:
        return None
    return value if value is not None and math.isfinite(value) else None


@dataclass
class RobotView:
    history_len: int = 300
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _mode: Stamped = field(default_factory=Stamped)
    _looks: dict[str, LedLook] = field(default_factory=dict)
    _diag: Stamped = field(default_factory=Stamped)  # {"link": (level, message), "odometry": ..., "checks": [...]}
    _ack: Stamped = field(default_factory=Stamped)
    _autonomy: Stamped = field(default_factory=Stamped)  # the autonomy's commanded speed (m/s) while it drives
    _moves_sent: int | None = None
    _body_tilt: Stamped = field(default_factory=Stamped)
    _odom: Stamped = field(default_factory=Stamped)  # (speed m/s, tilt rad)
    _imu_tilt: Stamped = field(default_factory=Stamped)
    _history: deque = field(default_factory=deque)

    # --- what the bridge hands in ------------------------------------------------------------------
    def on_mode(self, fields: dict[str, Any], now: float) -> None:
        with self._lock:
            self._mode = Stamped(dict(fields), now)

    def set_looks(self, looks: dict[str, LedLook]) -> None:
        with self._lock:
            self._looks = dict(looks)

    def on_diagnostics(self, statuses: list[DiagStatus], now: float) -> None:
        """The mode manager's own statuses (the bridge filters by hardware id)."""
        by_name = {s.name.partition(": ")[2]: s for s in statuses}
        checks = [{"name": name.removeprefix("body "), "state": s.values.get("state", ""),
                   "value": _number(s.values.get("value")), "threshold": _number(s.values.get("threshold")),
                   "unit": s.values.get("unit", ""), "level": s.level}
                  for name, s in by_name.items() if name.startswith("body ")]
        summary = {"link": by_name.get("robot link"), "odometry": by_name.get("odometry")}
        with self._lock:
            self._diag = Stamped({"checks": checks, **{k: None if s is None else (s.level, s.message)
                                                        for k, s in summary.items()}}, now)
            tilt = next((c["value"] for c in checks if c["name"] == "tilt"), None)
            if tilt is not None:
                self._body_tilt = Stamped(tilt, now)
            commands, walking = by_name.get("commands"), by_name.get("walking")
            sent = None if commands is None else _number(commands.values.get("moves_sent"))
            if sent is not None and walking is not None:
                grew = self._moves_sent is not None and sent > self._moves_sent
                commanded = _number(walking.values.get("commanded_mps")) or 0.0
                self._ack = Stamped(commanded if grew else 0.0, now)
                self._moves_sent = int(sent)
            driver = by_name.get("driver")
            if driver is not None:
                self._autonomy = Stamped(_autonomy_speed(driver.values), now)

    def on_odom(self, vx: float, vy: float, quaternion: tuple[float, float, float, float], now: float) -> None:
        with self._lock:
            self._odom = Stamped((math.hypot(vx, vy), tilt_of(*quaternion)), now)

    def on_imu(self, quaternion: tuple[float, float, float, float], now: float) -> None:
        with self._lock:
            self._imu_tilt = Stamped(tilt_of(*quaternion), now)

    # --- what the server asks --------------------------------------------------------------------------
    def drive_block(self, now: float) -> str | None:
        """Why no cmd_vel should be published now (the node would drop it), or None."""
        with self._lock:
            mode = self._mode.fresh(now, MODE_SILENT_S)
        if mode is None:
            return "no ~/mode from the mode manager"
        if mode["name"] != Mode.HIGH_LEVEL.name:
            return f"{mode['name']}: driving needs HIGH_LEVEL"
        if mode["transition_in_progress"]:
            return "a transition is in progress"
        if mode["holds"]:
            return f"motion held: {'; '.join(mode['holds'])}"
        if mode["robot_mismatch"]:
            return f"robot mismatch: {mode['robot_mismatch']}"
        return None

    def snapshot(self, now: float) -> dict[str, Any]:
        with self._lock:
            mode, age = self._mode.value, now - self._mode.at
            look = None if mode is None else self._looks.get(_look_key(mode))
            diag = self._diag.fresh(now, DIAGNOSTICS_STALE_S)
        body = None
        if diag is not None and diag["checks"]:
            values = {c["name"]: c["value"] for c in diag["checks"]}
            body = {key: values.get(check) for key, check in BODY_SUMMARY.items()}
            body["checks"] = diag["checks"]
        led = None if look is None else {"rgb": list(look.rgb), "pattern": look.pattern.value, "period_s": look.period_s}
        link = None if diag is None or diag["link"] is None else {"level": diag["link"][0], "message": diag["link"][1]}
        return {
            "mode": mode,
            "mode_age_s": None if mode is None else round(age, 2),
            "mode_fresh": mode is not None and age <= MODE_SILENT_S,
            "led": led,
            "link": link,
            "odometry": None if diag is None or diag["odometry"] is None else diag["odometry"][1],
            "body": body,
        }

    def sample(self, now: float, t: float, commanded: tuple[float, float, float] | None) -> dict[str, Any]:
        """One plot point at ``now`` (monotonic), stamped ``t`` (s since the console started), kept in the history."""
        with self._lock:
            odom = self._odom.fresh(now, FAST_STALE_S)
            tilt = self._imu_tilt.fresh(now, FAST_STALE_S)
            if tilt is None and odom is not None:
                tilt = odom[1]
            if tilt is None:
                tilt = self._body_tilt.fresh(now, DIAGNOSTICS_STALE_S)
            point = {"t": round(t, 3),
                     "cmd": 0.0 if commanded is None else round(math.hypot(commanded[0], commanded[1]), 4),
                     "cmd_wz": 0.0 if commanded is None else round(commanded[2], 4),
                     "ack": self._ack.fresh(now, DIAGNOSTICS_STALE_S),
                     "meas": None if odom is None else round(odom[0], 4),
                     "auto": self._autonomy.fresh(now, DIAGNOSTICS_STALE_S),
                     "tilt": None if tilt is None or not math.isfinite(tilt) else round(tilt, 4)}
            self._history.append(point)
            while len(self._history) > self.history_len:
                self._history.popleft()
            return point

    def history(self) -> list[dict[str, Any]]:
        with self._lock:
            return list(self._history)


def mode_fields(msg: Any) -> dict[str, Any]:
    """The fields of a g1_mode_manager_msgs/Mode the page shows (duck-typed: no ROS import here)."""
    try:
        target = Mode(msg.transition_target).name
    except ValueError:
        target = str(msg.transition_target)
    service = ("unknown" if not msg.high_level_service_known
               else "active" if msg.high_level_service_active else "released")
    return {"name": msg.name, "value": int(msg.mode), "transition_in_progress": bool(msg.transition_in_progress),
            "transition_target": target, "damp_confirmed": bool(msg.damp_confirmed), "link_ok": bool(msg.link_ok),
            "high_level_service": service, "last_refusal": msg.last_refusal, "last_error": msg.last_error,
            "robot_mismatch": msg.robot_mismatch, "reasserts": int(msg.reasserts), "faults": list(msg.faults),
            "holds": list(msg.holds), "warnings": list(msg.warnings), "driver": msg.driver,
            "autonomy_suspended": msg.autonomy_suspended, "posture": msg.posture}


def _look_key(mode: dict[str, Any]) -> str:
    """Whose look the head LED shows: the mode's, or the autonomy's while it drives (as the node's LED does)."""
    autonomy = mode["name"] == Mode.HIGH_LEVEL.name and mode["driver"] == Driver.AUTONOMY.value
    return AUTONOMY_LOOK if autonomy else mode["name"]


def _autonomy_speed(values: dict[str, str]) -> float | None:
    """The autonomy's commanded speed in the plane (m/s) from the driver status, None unless it drives."""
    if values.get("driver") != Driver.AUTONOMY.value:
        return None
    vx, vy = _number(values.get("autonomy_vx")), _number(values.get("autonomy_vy"))
    return None if vx is None or vy is None else round(math.hypot(vx, vy), 4)
