"""The Policy card's picture, from what the mode manager publishes about the policy in its loop: ``~/policy/status``,
the policy's latest targets (``~/policy/targets``) and the measured joints (``joint_states``). Pure, as RobotView:
the bridge hands in plain values with the time they arrived, the server asks for a snapshot and a plot sample.

The plotted error is the largest |target - measured| over the joints, from the latest message of each stream while
both are fresh. The two are not of the same tick (the targets come at the node's publish rate, the joints at their
own), so it may differ from the status' ``max_target_error_rad`` (one tick's, at 2 Hz) by what the joints moved in
between; it is there to watch the policy agree with the robot before an engage, and follow it after.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from g1_mode_manager.console.robot_view import FAST_STALE_S, Stamped
from g1_mode_manager.core.controller.phases import Phase
from g1_mode_manager.protocol.motors import JOINT_NAMES

#: Shown before the node's first status (it publishes one, latched, at start): no policy.
NO_STATUS_PHASE = Phase.UNLOADED.value


def _finite(value: float, digits: int) -> float | None:
    """Rounded, or None for a value JSON cannot carry (NaN, inf)."""
    value = float(value)
    return round(value, digits) if math.isfinite(value) else None


def _optional(value: float, digits: int) -> float | None:
    """The status' -1 ("not this kind of policy") as None."""
    return None if value < 0 else _finite(value, digits)


def status_fields(msg: Any) -> dict[str, Any]:
    """The fields of a g1_mode_manager_msgs/PolicyStatus the card shows (duck-typed: no ROS import here)."""
    return {"policy": msg.policy, "phase": msg.phase, "rate_hz": _finite(msg.rate_hz, 1),
            "inference_p99_ms": _finite(msg.inference_p99_ms, 2), "tick_p99_ms": _finite(msg.tick_p99_ms, 2),
            "ticks": int(msg.ticks), "overruns": int(msg.overruns), "skipped": int(msg.skipped),
            "blend": _finite(msg.blend, 3), "progress": _optional(msg.progress, 3),
            "max_target_error_rad": _finite(msg.max_target_error_rad, 4),
            "tracking_error_rad": _optional(msg.tracking_error_rad, 4), "last_fault": msg.last_fault,
            "action_scale": msg.action_scale, "state_to_frame_p99_ms": _finite(msg.state_to_frame_p99_ms, 2),
            "frame_jitter_p99_ms": _finite(msg.frame_jitter_p99_ms, 2),
            "clamped": {JOINT_NAMES[i]: int(n) for i, n in enumerate(msg.clamps) if n and i < len(JOINT_NAMES)}}


def in_motor_order(names: Sequence[str], positions: Sequence[float]) -> list[float] | None:
    """``positions`` by joint name in the G1's motor order; None unless every joint is there and finite."""
    by_name = dict(zip(names, positions, strict=False))
    try:
        ordered = [float(by_name[name]) for name in JOINT_NAMES]
    except KeyError:
        return None
    return ordered if all(math.isfinite(q) for q in ordered) else None


@dataclass
class PolicyView:
    history_len: int = 300
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _status: dict[str, Any] | None = None
    _params: dict[str, Any] = field(default_factory=lambda: {"default": None, "engage_limit_rad": None})
    #: (names, positions) as they came: put in motor order only when the state goes out, slower than they come
    _targets: Stamped = field(default_factory=Stamped)
    _measured: Stamped = field(default_factory=Stamped)
    _history: deque = field(default_factory=deque)

    # --- what the bridge hands in ------------------------------------------------------------------
    def on_status(self, fields: dict[str, Any]) -> None:
        """Published at every change of phase (latched) and at 2 Hz while the loop ticks: never stale by age."""
        with self._lock:
            self._status = dict(fields)

    def set_params(self, default: str | None, engage_limit_rad: float | None) -> None:
        """The node's default policy (what LOAD loads with no name) and its engage bound; None: not known."""
        with self._lock:
            self._params = {"default": default, "engage_limit_rad": engage_limit_rad}

    def on_targets(self, names: Sequence[str], positions: Sequence[float], now: float) -> None:
        with self._lock:
            self._targets = Stamped((names, positions), now)

    def on_joints(self, names: Sequence[str], positions: Sequence[float], now: float) -> None:
        with self._lock:
            self._measured = Stamped((names, positions), now)

    # --- what the server asks --------------------------------------------------------------------------
    def snapshot(self, now: float) -> dict[str, Any]:
        """The status (a stand-in saying unloaded before the first), the latest targets and measured joints in motor
        order while both are fresh (None otherwise: the loop does not tick, or no joint_states), and the node's
        default policy and engage bound."""
        target, measured = self._pair(now)
        with self._lock:
            status, params = self._status, dict(self._params)
        if status is None:
            status = {"policy": "", "phase": NO_STATUS_PHASE, "no_status": True}
        joints = None
        if target is not None and measured is not None:
            joints = {"target": [round(q, 4) for q in target], "measured": [round(q, 4) for q in measured]}
        return {"status": status, "joints": joints, **params}

    def sample(self, now: float, t: float) -> dict[str, Any]:
        """One plot point at ``now`` (monotonic), stamped ``t`` (the console's plot time), kept in the history:
        the largest |target - measured|, or None (a gap) while either stream is stale."""
        target, measured = self._pair(now)
        err = None
        if target is not None and measured is not None:
            err = round(max(abs(a - b) for a, b in zip(target, measured, strict=True)), 4)
        point = {"t": round(t, 3), "err": err}
        with self._lock:
            self._history.append(point)
            while len(self._history) > self.history_len:
                self._history.popleft()
        return point

    def history(self) -> list[dict[str, Any]]:
        with self._lock:
            return list(self._history)

    def _pair(self, now: float) -> tuple[list[float] | None, list[float] | None]:
        with self._lock:
            targets, measured = self._targets.fresh(now, FAST_STALE_S), self._measured.fresh(now, FAST_STALE_S)
        return (None if targets is None else in_motor_order(*targets),
                None if measured is None else in_motor_order(*measured))
