"""One incident file: the flight ring's entries of a window as an MCAP file of ROS 2 messages (cdr, ros2msg
schemas embedded), which Foxglove and ros2 bag's MCAP tools open as a bag.

Typed messages where a standard one fits (std_msgs/Float64 for each body reading, geometry_msgs/Twist for the
drivers' commands, the Moves and the robot's odometry, this package's JointCommand for frames); std_msgs/String
holding one JSON object where none does (the mode machine, robot calls, notes), on the channels that
core/recorder/channels.py names. Each message's log time is when the node saw the
thing; a robot call's answer has its request's time as publish time. Runs in the child the recorder forks for the file
(forked_write), never on a hook's thread; run in a process with other threads, it lets them have the GIL every
YIELD_EVERY messages.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Final

from mcap.records import Schema
from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

from g1_mode_manager.core.body.checks import CHECKS
from g1_mode_manager.core.recorder.channels import (
    BODY,
    BODY_READINGS,
    DRIVE,
    ESTOP,
    FRAMES,
    MOVES,
    NOTES,
    ODOMETRY,
    ROBOT_CALLS,
    SERVICES,
    STATUS,
    TRANSITIONS,
)
from g1_mode_manager.core.recorder.events import (
    FRAME_FIELDS,
    Attempt,
    BodyStep,
    DriveInput,
    EstopStep,
    Event,
    FrameSent,
    MoveSent,
    Note,
    OdometrySeen,
    Phase,
    RobotCall,
    ServiceAnswer,
    StatusChange,
)
from g1_mode_manager.core.recorder.incidents import METADATA_NAME
from g1_mode_manager.core.recorder.ring import Entry
from g1_mode_manager.flight_recorder import ros2_schemas as schemas
from g1_mode_manager.protocol.motors import ARM_SDK_JOINT_NAMES, JOINT_NAMES
from g1_mode_manager.protocol.odom_fields import rotate_into_body

#: Messages written between two looks for other threads (time.sleep(0) hands the GIL over).
YIELD_EVERY: Final = 200
_FRAME_NAMES: Final = {"lowcmd": JOINT_NAMES, "user_lowcmd": JOINT_NAMES, "arm_sdk": ARM_SDK_JOINT_NAMES}
_CHECK_NAMES: Final = tuple(c.name for c in CHECKS)


def write_incident(path: Path, entries: Sequence[Entry], metadata: Mapping[str, str], *,
                   to_unix: Callable[[float], float]) -> int:
    """Write ``entries`` (in their order) to ``path``; ``to_unix`` turns an entry's clock into UNIX seconds.
    Returns how many messages were written. The file is synced before this returns."""
    with open(path, "wb") as stream:
        writer = Writer(stream, compression=CompressionType.ZSTD)
        writer.add_metadata(METADATA_NAME, dict(metadata))
        out = _Messages(writer, to_unix)
        for t, order, event in entries:
            out.event(t, order, event)
        writer.finish()
        stream.flush()
        os.fsync(stream.fileno())
    return out.count


class _Messages:
    def __init__(self, writer: Writer, to_unix: Callable[[float], float]) -> None:
        self._writer = writer
        self._to_unix = to_unix
        self._schemas: dict[str, Schema] = {name: writer.register_msgdef(name, text) for name, text in schemas.ALL}
        self._verdicts: tuple[str, ...] | None = None
        self.count = 0

    def _write(self, topic: str, schema: tuple[str, str], message: Any, t: float, order: int,
               published: float | None = None) -> None:
        log_ns = int(self._to_unix(t) * 1e9)
        publish_ns = log_ns if published is None else int(self._to_unix(published) * 1e9)
        self._writer.write_message(topic, self._schemas[schema[0]], message, log_time=log_ns,
                                   publish_time=publish_ns, sequence=order & 0xFFFFFFFF)
        self.count += 1
        if self.count % YIELD_EVERY == 0:
            time.sleep(0)

    def _json(self, topic: str, t: float, order: int, value: object, published: float | None = None) -> None:
        self._write(topic, schemas.STRING, {"data": json.dumps(value, default=str)}, t, order, published)

    def event(self, t: float, order: int, event: Event) -> None:
        match event:
            case StatusChange(status=s):
                self._json(STATUS, t, order, {
                    "mode": s.mode.name, "transition_target": s.transition_target.name if s.transition_target else None,
                    "service": "unknown" if not s.service_known else ("active" if s.service_active else "released"),
                    "damp_confirmed": s.damp_confirmed, "faults": list(s.faults), "holds": list(s.holds),
                    "robot_mismatch": s.robot_mismatch, "last_refusal": s.last_refusal, "last_error": s.last_error,
                    "reasserts": s.reasserts, "version": s.version})
            case Attempt(record=r):
                self._json(TRANSITIONS, t, order, {"from": r.source.name, "to": r.target.name,
                                                   "outcome": r.outcome.value, "duration_s": round(r.duration_s, 4),
                                                   "message": r.message})
            case Note(level=level, text=text):
                self._json(NOTES, t, order, {"level": level, "text": text})
            case ServiceAnswer():
                self._json(SERVICES, t, order, {"service": event.service, "request": event.request,
                                                "success": event.success, "message": event.message})
            case RobotCall():
                self._call(t, order, event)
            case BodyStep(readings=r, verdicts=verdicts):
                for field, channel in BODY_READINGS.items():
                    value = getattr(r, field)
                    if value is not None:
                        self._write(f"{BODY}/{channel}", schemas.FLOAT64, {"data": value}, t, order)
                if verdicts != self._verdicts:  # each change, and the first in the file
                    self._verdicts = verdicts
                    self._json(f"{BODY}/verdicts", t, order, dict(zip(_CHECK_NAMES, verdicts, strict=False)))
            case DriveInput():
                self._write(f"{DRIVE}/{event.source}", schemas.TWIST, _twist(event.vx, event.vy, event.wz), t, order)
                if not event.taken:
                    self._json(f"{DRIVE}/not_taken", t, order, {"source": event.source})
            case MoveSent():
                self._write(f"{MOVES}/{event.driver}", schemas.TWIST, _twist(event.vx, event.vy, event.wz), t, order)
            case EstopStep():
                self._json(ESTOP, t, order, {"step": event.step, "via": event.via, "detail": event.detail})
            case FrameSent():
                self._frame(t, order, event)
            case OdometrySeen():  # as the node's odom publishes its twist: in the body frame (REP 105)
                vx, vy, _vz = rotate_into_body(event.quaternion, event.velocity)
                self._write(ODOMETRY, schemas.TWIST, _twist(vx, vy, event.yaw_speed), t, order)

    def _call(self, t: float, order: int, call: RobotCall) -> None:
        value: dict[str, object] = {"id": call.call_id, "verb": call.verb.name, "api": call.verb.api,
                                    "parameter": dict(zip(call.verb.parameters, call.args, strict=False)),
                                    "phase": call.phase.value}
        published = None
        if call.phase is not Phase.REQUEST:
            value["code"] = call.code
            if call.error:
                value["error"] = call.error
        if call.phase is Phase.ANSWER:
            value["answer"] = call.answer
            value["latency_ms"] = None if call.latency_s is None else round(call.latency_s * 1e3, 3)
            published = None if call.latency_s is None else t - call.latency_s
        self._json(ROBOT_CALLS, t, order, value, published)

    def _frame(self, t: float, order: int, frame: FrameSent) -> None:
        n = len(FRAME_FIELDS)
        columns = {field: list(frame.values[i::n]) for i, field in enumerate(FRAME_FIELDS)}
        names = _FRAME_NAMES.get(frame.topic, JOINT_NAMES)[:len(frame.values) // n]
        unix = self._to_unix(t)
        stamp = {"sec": int(unix), "nanosec": int((unix - int(unix)) * 1e9)}
        self._write(f"{FRAMES}/{frame.topic}", schemas.JOINT_COMMAND, {"stamp": stamp, "name": list(names), **columns},
                    t, order)
        if frame.weight is not None:
            self._write(f"{FRAMES}/{frame.topic}/weight", schemas.FLOAT64, {"data": frame.weight}, t, order)


def _twist(vx: float, vy: float, wz: float) -> dict[str, dict[str, float]]:
    return {"linear": {"x": vx, "y": vy, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": wz}}
