"""Incident files as the node writes them, for the console's tests: an e-stop while walking recorded through the
product's own parts (the flight ring, the recording robot port around a fake robot, the incident folder's writer),
at a chosen UNIX time."""

from __future__ import annotations

import math
from pathlib import Path

from fakes.fake_clock import FakeClock
from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import OdomSample
from g1_mode_manager.core.recorder.events import BodyStep, EstopStep, Kind, MoveSent, StatusChange
from g1_mode_manager.core.recorder.incidents import Cause
from g1_mode_manager.core.recorder.ring import FlightRing, caps_for
from g1_mode_manager.core.records import MachineStatus
from g1_mode_manager.flight_recorder.incident_folder import IncidentFolder
from g1_mode_manager.flight_recorder.recording_port import recording_port
from g1_mode_manager.protocol.odom_fields import OdomFields

EPOCH = 1_795_000_000.0  # UNIX time of the fake clock's 0
STOP = 100.0  # when the e-stop's EMERGENCY is entered, on the fake clock
WINDOW_S, AFTER_S = 30.0, 2.0
#: The body turned 90 degrees left of the odometry frame: walking along its own x is along the frame's y.
YAW_90 = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))
VIA = "/g1_mode_manager/estop"


def _status(mode: Mode, version: int, *, damp_confirmed: bool = False) -> StatusChange:
    return StatusChange(MachineStatus(mode, False, None, True, True, damp_confirmed, "", "", version=version))


def _odom(port: FakeRobotPort, count: int, vy: float) -> None:
    fields = OdomFields(stamp_s=float(count), position=(0.0, 0.0, 0.75), velocity=(0.0, vy, 0.0), yaw_speed=0.2,
                        quaternion=YAW_90, gyroscope=(0.0, 0.0, 0.2), rpy=(0.0, 0.0, math.pi / 2), body_height=0.75)
    port.odom = OdomSample(fields, 0.01, count)


def estop_incident(folder: Path, *, began: float = EPOCH + STOP, tilts: int = 0) -> Path:
    """An e-stop while walking, as the node records it: the ring filled by the recording robot port (its calls and
    the odometry it reads) and the hooks' events, written by the incident folder as the flight recorder does."""
    clock = FakeClock(STOP - 40.0)
    ring = FlightRing({**caps_for(WINDOW_S + AFTER_S), Kind.BODY: 10**5}, clock)  # room for a long window's tilt
    robot = FakeRobotPort()
    robot.connect()
    port = recording_port(robot, ring.add, frame_period_s=0.1, clock=clock)
    ring.add(_status(Mode.HIGH_LEVEL, 1))  # before the window: the file keeps it as the mode the window began in
    clock.advance(35.0)  # -5 s
    port.damp()  # a damp asked seconds before the stop: not one of its steps
    for i in range(tilts):  # a long window's body readings at 100 Hz, with a peak
        ring.add(BodyStep(BodyReadings(tilt_rad=1.5 if i == tilts // 2 else 0.05), ()), clock() - 20.0 + i * 0.001)
    for i in range(20):  # walking for 4 s: a Move every 0.2 s, the odometry read at each
        ring.add(MoveSent("teleop", 0.3, 0.0, 0.1))
        port.send_velocity(0.3, 0.0, 0.1, 1.0).wait()
        _odom(robot, i + 1, 0.25)
        port.odometry()
        port.odometry()  # read again by another part: the sample is kept once
        ring.add(BodyStep(BodyReadings(tilt_rad=0.05 + 0.01 * i), ()))
        clock.advance(0.2)
    port.set_velocity(0.0, 0.0, 0.0, 1.0)  # a StopMove at -1 s: the command is zero from there
    clock.advance(1.0)
    port.damp_no_reply()  # the e-stop's first packet, then its request noted
    ring.add(EstopStep("request", VIA))
    ring.add(_status(Mode.EMERGENCY, 2))
    clock.advance(0.001)
    port.damp()
    clock.advance(0.5)
    ring.add(BodyStep(BodyReadings(tilt_rad=0.4), ()))
    ring.add(_status(Mode.EMERGENCY, 3, damp_confirmed=True))
    ring.add(EstopStep("answer", VIA, "success=True: e-stop: robot damped"))
    clock.advance(AFTER_S - 0.501)
    offset = began - STOP  # the fake clock -> UNIX time, the stop at ``began``
    metadata = {"cause": f"EMERGENCY from HIGH_LEVEL ({VIA})", "mode": "EMERGENCY", "began": f"{began:.3f}",
                "window_s": f"{WINDOW_S:g}", "after_s": f"{AFTER_S:.3f}", "node": "/g1_mode_manager"}
    end = clock()
    path, _count = IncidentFolder(folder, max_files=50, max_bytes=10**9).write(
        began, Cause.EMERGENCY, lambda: ring.entries(STOP - WINDOW_S, end), metadata,
        to_unix=lambda t: t + offset)
    return path
