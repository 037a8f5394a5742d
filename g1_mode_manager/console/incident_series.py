"""One incident file read into what the console's incident card shows: its summary (when, cause, mode), plot series
(tilt, the Moves commanded, the velocity the robot's odometry measured, the mode over time) and the e-stop's steps,
every time in seconds from the stop (the file's ``began``).

Read with the ``mcap`` reader and ``mcap_ros2``'s decoder only, as any other reader of the file would (channels:
core/recorder/channels.py, docs/recorder.md); only the channels plotted are decoded. A file that cannot be read
raises :class:`UnreadableIncidentError` with why.
"""

from __future__ import annotations

import json
import math
from typing import Any, Final

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from g1_mode_manager.core.recorder.channels import ESTOP, MOVES, ODOMETRY, ROBOT_CALLS, STATUS, TILT
from g1_mode_manager.core.recorder.incidents import METADATA_NAME, IncidentFile

#: The stop's own first steps (its first packet, the e-stop's request) come within milliseconds of its entry; a step
#: this long before it is still the stop's, anything earlier in the window is not (a damp asked before, say).
STEPS_LEAD_S: Final = 1.0
#: Points of one series at most: a long window at the body check's 100 Hz is thinned, its peaks kept.
MAX_POINTS: Final = 2000
#: The robot calls that are e-stop steps (a StopMove is not a step, but ends the commanded velocity).
STEP_VERBS: Final = ("DampNoReply", "Damp")
SET_VELOCITY: Final = "SetVelocity"
STOPS: Final = ("EMERGENCY", "FAULT")

Point = list[float]  # [t, value]


class UnreadableIncidentError(Exception):
    """The file is not a complete incident (truncated, corrupt, not MCAP): the message says why."""


def read_incident(incident: IncidentFile) -> dict[str, Any]:
    """The card's content of ``incident``: summary, ``series`` (name -> [[t, value], ...]), ``modes`` ([[t, mode],
    ...] at each change) and ``steps`` ([{t, step, detail}, ...]), in seconds from the stop."""
    try:
        with open(incident.path, "rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            meta = next((m.metadata for m in reader.iter_metadata() if m.name == METADATA_NAME), {})
            summary = reader.get_summary()
            if summary is None:
                raise UnreadableIncidentError("it has no summary section (written by another program?)")
            topics = [c.topic for c in summary.channels.values() if _plotted(c.topic)]
            messages = [(channel.topic, message.log_time, decoded) for _s, channel, message, decoded
                        in reader.iter_decoded_messages(topics=topics, log_time_order=True)] if topics else []
    except UnreadableIncidentError:
        raise
    except Exception as exc:  # any damage: a truncated file ends in EndOfFile, a foreign one in InvalidMagic ...
        raise UnreadableIncidentError(f"{type(exc).__name__}: {exc}".rstrip(": ")) from exc
    began = _number(meta.get("began")) or incident.began
    window_s, after_s = _number(meta.get("window_s")), _number(meta.get("after_s"))
    content = _Content(began)
    for topic, log_time, msg in messages:
        content.take(topic, log_time * 1e-9 - began, msg)
    times = [t for series in content.series.values() for t, _v in series]
    start = -window_s if window_s is not None else min(times, default=0.0)
    end = after_s if after_s is not None else max(times, default=0.0)
    return {"name": incident.path.name, "size": incident.size, "began": began, "kind": incident.cause.value,
            "cause": meta.get("cause", incident.cause.value), "mode": meta.get("mode", "?"),
            "node": meta.get("node", ""), "start": round(start, 3), "end": round(end, 3),
            "series": {name: _thin(points) for name, points in content.series.items()},
            "modes": [[round(max(t, start), 3), mode] for t, mode in content.modes],
            "steps": content.steps_from(-STEPS_LEAD_S)}


def _plotted(topic: str) -> bool:
    return topic in (TILT, ODOMETRY, STATUS, ESTOP, ROBOT_CALLS) or topic.startswith(f"{MOVES}/")


def _number(text: str | None) -> float | None:
    try:
        value = float(text) if text is not None else math.nan
    except ValueError:
        return None
    return value if math.isfinite(value) else None


class _Content:
    """The series, modes and steps, filled message by message in log time order."""

    def __init__(self, began: float) -> None:
        self.began = began
        self.series: dict[str, list[Point]] = {"tilt": [], "cmd_vx": [], "cmd_wz": [], "meas_vx": [], "meas_wz": []}
        self.modes: list[tuple[float, str]] = []
        self._steps: list[tuple[float, str, str]] = []
        self._stop_entered = False
        self._damp_confirmed = False

    def take(self, topic: str, t: float, msg: Any) -> None:
        if topic == TILT:
            self._point("tilt", t, msg.data)
        elif topic == ODOMETRY:
            self._point("meas_vx", t, msg.linear.x)
            self._point("meas_wz", t, msg.angular.z)
        elif topic.startswith(f"{MOVES}/"):
            self._point("cmd_vx", t, msg.linear.x)
            self._point("cmd_wz", t, msg.angular.z)
        elif topic == STATUS:
            self._status(t, json.loads(msg.data))
        elif topic == ESTOP:
            e = json.loads(msg.data)
            self._steps.append((t, f"e-stop {e.get('step', '?')}", e.get("detail") or e.get("via", "")))
        elif topic == ROBOT_CALLS:
            self._call(t, json.loads(msg.data))

    def _point(self, name: str, t: float, value: float) -> None:
        if math.isfinite(value):
            self.series[name].append([round(t, 3), round(value, 4)])

    def _status(self, t: float, status: dict[str, Any]) -> None:
        mode = str(status.get("mode", "?"))
        if not self.modes or self.modes[-1][1] != mode:
            self.modes.append((t, mode))
            if mode in STOPS:
                self._steps.append((t, f"{mode} entered", ", ".join(status.get("faults") or ())))
        if mode in STOPS and status.get("damp_confirmed") and not self._damp_confirmed:
            self._steps.append((t, "damp_confirmed", "the robot is seen damped"))
        self._damp_confirmed = bool(status.get("damp_confirmed")) and mode in STOPS

    def _call(self, t: float, call: dict[str, Any]) -> None:
        verb, phase = call.get("verb"), call.get("phase")
        if verb == SET_VELOCITY and phase == "request":
            p = call.get("parameter") or {}
            if not any(p.get(k) for k in ("vx", "vy", "wz")):  # a StopMove: the command is zero from here
                self._point("cmd_vx", t, 0.0)
                self._point("cmd_wz", t, 0.0)
        if verb not in STEP_VERBS:
            return
        detail = ""
        if phase == "answer":  # a request has no outcome yet, a packet sent without reply has none to come
            detail = f"code {call.get('code', '?')}"
            if call.get("latency_ms") is not None:
                detail += f", {call['latency_ms']:.0f} ms"
        if call.get("error"):
            detail += f"{': ' if detail else ''}{call['error']}"
        what = {"request": "request", "answer": "answer", "no_reply": "sent"}.get(str(phase), str(phase))
        self._steps.append((t, f"{verb} {what}", detail))

    def steps_from(self, start: float) -> list[dict[str, Any]]:
        return [{"t": round(t, 3), "step": step, "detail": detail} for t, step, detail in self._steps if t >= start]


def _thin(points: list[Point], limit: int = MAX_POINTS) -> list[Point]:
    """At most about ``limit`` points: each run of points is kept as its lowest and highest, in time order, so a
    peak (a fall's tilt) survives the thinning."""
    if len(points) <= limit:
        return points
    run = math.ceil(2 * len(points) / limit)
    out: list[Point] = []
    for i in range(0, len(points), run):
        chunk = points[i:i + run]
        lo, hi = min(chunk, key=lambda p: p[1]), max(chunk, key=lambda p: p[1])
        out.extend(sorted({id(lo): lo, id(hi): hi}.values(), key=lambda p: p[0]))
    return out

