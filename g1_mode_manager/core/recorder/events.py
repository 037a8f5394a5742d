"""What the flight recorder keeps: one small immutable event per thing the node saw or did.

The hooks build these in the threads that saw the thing, so each holds references to what those threads made
anyway (a MachineStatus, a BodyReadings) and converts nothing but a kept frame (packed into an array): the writer
turns them into messages later, on its own thread.
"""

from __future__ import annotations

from array import array
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import ClassVar

from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.core.records import MachineStatus, TransitionRecord


class Kind(StrEnum):
    """Each kind has a ring of its own, so a flood of one never pushes another out of the window."""

    STATUS = "status"  # the mode machine's status at each change
    TRANSITION = "transition"  # every mode change attempt with its outcome and reason, refusals included
    NOTE = "note"  # what the node's parts logged (a relay's drop, a StopMove, the remote's e-stop)
    SERVICE = "service"  # a service's answer (loco_command, clear_fault, hand-over, take-over)
    CALL = "call"  # a robot call: its request and its answer
    BODY = "body"  # one body check step: the readings and each check's verdict
    DRIVE = "drive"  # a driver's velocity command as it arrived
    MOVE = "move"  # a Move the cmd_vel relay wrote, and who drove
    ESTOP = "estop"  # an e-stop request as the endpoint took it, and its answer
    FRAME = "frame"  # a joint frame written to the robot (decimated)
    ODOMETRY = "odometry"  # the robot's state estimate (rt/lf/odommodestate) as a part of the node read it


@dataclass(frozen=True, slots=True)
class StatusChange:
    kind: ClassVar[Kind] = Kind.STATUS
    status: MachineStatus


@dataclass(frozen=True, slots=True)
class Attempt:
    kind: ClassVar[Kind] = Kind.TRANSITION
    record: TransitionRecord


@dataclass(frozen=True, slots=True)
class Note:
    kind: ClassVar[Kind] = Kind.NOTE
    level: str  # info, warn, error
    text: str


@dataclass(frozen=True, slots=True)
class ServiceAnswer:
    kind: ClassVar[Kind] = Kind.SERVICE
    service: str
    request: str
    success: bool
    message: str


@dataclass(frozen=True, slots=True)
class Verb:
    """A robot call as the robot names it: its api id (0: none, e.g. connect) and its parameters' names."""

    name: str
    api: int
    parameters: tuple[str, ...] = ()


class Phase(StrEnum):
    REQUEST = "request"  # written; its answer is another event, or none if it is still awaited
    ANSWER = "answer"
    NO_REPLY = "no_reply"  # written with no answer to come (DampNoReply)


@dataclass(frozen=True, slots=True)
class RobotCall:
    kind: ClassVar[Kind] = Kind.CALL
    call_id: int  # the same for a request and its answer
    verb: Verb
    args: tuple[object, ...]  # in the order of verb.parameters
    phase: Phase
    code: int = 0  # the robot's return code (0 ok; 3104 no answer in time ...)
    answer: object = None  # a getter's value (the fsm id, the service's name)
    latency_s: float | None = None  # from the write to the answer
    error: str = ""


@dataclass(frozen=True, slots=True)
class BodyStep:
    kind: ClassVar[Kind] = Kind.BODY
    readings: BodyReadings
    verdicts: tuple[str, ...]  # each check's state (core/body/monitor.py), in the order of core/body/checks.CHECKS


@dataclass(frozen=True, slots=True)
class DriveInput:
    kind: ClassVar[Kind] = Kind.DRIVE
    source: str  # the driver the command came from: teleop or autonomy
    vx: float
    vy: float
    wz: float
    taken: bool  # it counts: its source drives (a teleop command while the autonomy drives takes the robot back)


@dataclass(frozen=True, slots=True)
class MoveSent:
    kind: ClassVar[Kind] = Kind.MOVE
    driver: str
    vx: float
    vy: float
    wz: float


@dataclass(frozen=True, slots=True)
class EstopStep:
    kind: ClassVar[Kind] = Kind.ESTOP
    step: str  # request, answer
    via: str  # the service or topic it came by
    detail: str = ""


@dataclass(frozen=True, slots=True)
class OdometrySeen:
    """One sample of the robot's estimate, its tuples as the reader made them: turned into the body frame only
    when written."""

    kind: ClassVar[Kind] = Kind.ODOMETRY
    velocity: tuple[float, float, float]  # m/s, in the odometry frame
    yaw_speed: float  # rad/s
    quaternion: tuple[float, float, float, float]  # (w, x, y, z) of the body in the odometry frame


#: A frame's fields of each motor, in this order, in FrameSent.values.
FRAME_FIELDS = ("q", "dq", "tau", "kp", "kd")


@dataclass(frozen=True, slots=True)
class FrameSent:
    kind: ClassVar[Kind] = Kind.FRAME
    topic: str  # lowcmd, user_lowcmd, arm_sdk
    values: array[float]  # FRAME_FIELDS of each motor the frame commands, motor after motor: 8 bytes a value
    weight: float | None = None  # arm_sdk's blend weight

    @staticmethod
    def of(topic: str, commands: Sequence[MotorCommand], weight: float | None = None) -> FrameSent:
        """Packed into doubles: a frame's MotorCommands, kept as they are, would take several times the memory
        (docs/recorder.md)."""
        values = array("d")
        for c in commands:
            values.extend((c.q, c.dq, c.tau, c.kp, c.kd))
        return FrameSent(topic, values, weight)


Event = (StatusChange | Attempt | Note | ServiceAnswer | RobotCall | BodyStep | DriveInput | MoveSent | EstopStep
         | FrameSent | OdometrySeen)
