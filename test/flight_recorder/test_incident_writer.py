"""An incident file read back with the mcap library's reader and mcap_ros2's decoder alone (no ROS, no package
messages): every kind of event as its message, in order, times kept, the schemas those of the interface files."""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from fakes.fake_clock import FakeClock
from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.joint_commands import DAMPING
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.core.recorder.events import (
    Attempt,
    BodyStep,
    DriveInput,
    EstopStep,
    FrameSent,
    MoveSent,
    Note,
    OdometrySeen,
    Phase,
    RobotCall,
    ServiceAnswer,
    StatusChange,
)
from g1_mode_manager.core.recorder.ring import FlightRing, caps_for
from g1_mode_manager.core.records import MachineStatus, Result, TransitionRecord
from g1_mode_manager.flight_recorder import incident_writer as w
from g1_mode_manager.flight_recorder import ros2_schemas
from g1_mode_manager.flight_recorder.recording_port import DAMP, SET_VELOCITY

EPOCH = 1_795_000_000.0  # what the fake clock's 0 is in UNIX time


def _ring() -> FlightRing:
    clock = FakeClock(10.0)
    ring = FlightRing(caps_for(60.0), clock)
    ok = ("ok",) * 10
    ring.add(StatusChange(MachineStatus(Mode.HIGH_LEVEL, False, None, True, True, False, "", "", version=3)))
    ring.add(DriveInput("teleop", 0.3, 0.0, 0.1, True))
    ring.add(MoveSent("teleop", 0.3, 0.0, 0.1))
    # the robot's estimate, the body turned 90 degrees left: its forward 0.3 m/s is along the odometry frame's y
    ring.add(OdometrySeen((0.0, 0.3, 0.0), 0.1, (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))))
    ring.add(RobotCall(1, SET_VELOCITY, (0.3, 0.0, 0.1, 1.0), Phase.REQUEST))
    clock.advance(0.004)
    ring.add(RobotCall(1, SET_VELOCITY, (0.3, 0.0, 0.1, 1.0), Phase.ANSWER, 0, None, 0.004))
    ring.add(FrameSent.of("arm_sdk", [MotorCommand(q=0.5, kp=60.0, kd=1.5)] * 17, 0.25))
    clock.advance(0.01)
    ring.add(BodyStep(BodyReadings(tilt_rad=0.2, gyro_max=0.5, soc_pct=80.0), ok))
    clock.advance(0.01)
    ring.add(BodyStep(BodyReadings(tilt_rad=1.2, gyro_max=3.0, soc_pct=80.0), ("tripping", *ok[1:])))
    ring.add(StatusChange(MachineStatus(Mode.FAULT, False, None, True, True, False, "", "", version=4,
                                        faults=("tilt: 1.20 rad > 1.00",))))
    ring.add(RobotCall(2, DAMP, (), Phase.REQUEST))
    ring.add(FrameSent.of("lowcmd", DAMPING))
    clock.advance(0.003)
    ring.add(RobotCall(2, DAMP, (), Phase.ANSWER, 3104, None, 0.003, "Damp failed: 3104 (timeout)"))
    ring.add(Note("error", "body check tripped"))
    ring.add(ServiceAnswer("loco_command", "start 0", False, "refused in FAULT"))
    ring.add(EstopStep("request", "~/estop"))
    ring.add(Attempt(TransitionRecord(Mode.FAULT, Mode.EMERGENCY, Result.OK, 0.2, "e-stop: robot damped")))
    return ring


def _read(path: Path) -> list[tuple[str, int, int, object]]:
    """(topic, log time, publish time, decoded message) of every message, in log time order."""
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [(channel.topic, message.log_time, message.publish_time, decoded)
                for _schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True)]


def test_every_event_reads_back_as_its_message_in_order(tmp_path: Path) -> None:
    path = tmp_path / "incident.mcap"
    entries = _ring().entries(0.0, 100.0)
    count = w.write_incident(path, entries, {"cause": "FAULT from HIGH_LEVEL: tilt", "mode": "FAULT"},
                             to_unix=lambda t: EPOCH + t)
    got = _read(path)
    assert len(got) == count
    topics = [topic for topic, *_ in got]
    assert topics == [
        w.STATUS, f"{w.DRIVE}/teleop", f"{w.MOVES}/teleop", w.ODOMETRY, w.ROBOT_CALLS, w.ROBOT_CALLS,
        f"{w.FRAMES}/arm_sdk", f"{w.FRAMES}/arm_sdk/weight",
        f"{w.BODY}/tilt_rad", f"{w.BODY}/gyro_max_rad_s", f"{w.BODY}/battery_soc_pct", f"{w.BODY}/verdicts",
        f"{w.BODY}/tilt_rad", f"{w.BODY}/gyro_max_rad_s", f"{w.BODY}/battery_soc_pct", f"{w.BODY}/verdicts",
        w.STATUS, w.ROBOT_CALLS, f"{w.FRAMES}/lowcmd", w.ROBOT_CALLS, w.NOTES, w.SERVICES, w.ESTOP, w.TRANSITIONS]
    log_times = [log for _t, log, _p, _m in got]
    assert log_times == sorted(log_times) and log_times[0] == int((EPOCH + 10.0) * 1e9)
    by_topic = {}
    for topic, _log, _pub, msg in got:
        by_topic.setdefault(topic, []).append(msg)
    assert [m.data for m in by_topic[f"{w.BODY}/tilt_rad"]] == [0.2, 1.2]
    assert json.loads(by_topic[w.STATUS][1].data)["faults"] == ["tilt: 1.20 rad > 1.00"]
    twist = by_topic[f"{w.MOVES}/teleop"][0]
    assert (twist.linear.x, twist.angular.z) == (0.3, 0.1)
    measured = by_topic[w.ODOMETRY][0]  # in the body frame, as the node's odom publishes its twist
    assert (measured.linear.x, measured.linear.y, measured.angular.z) == pytest.approx((0.3, 0.0, 0.1), abs=1e-12)
    calls = [json.loads(m.data) for m in by_topic[w.ROBOT_CALLS]]
    assert [(c["verb"], c["phase"]) for c in calls] == [("SetVelocity", "request"), ("SetVelocity", "answer"),
                                                        ("Damp", "request"), ("Damp", "answer")]
    assert calls[0]["parameter"] == {"vx": 0.3, "vy": 0.0, "wz": 0.1, "duration_s": 1.0}
    assert calls[1]["latency_ms"] == 4.0 and calls[1]["code"] == 0 and calls[1]["api"] == 7105
    assert calls[3]["code"] == 3104 and "timeout" in calls[3]["error"]
    answer = next(g for g in got if g[0] == w.ROBOT_CALLS and json.loads(g[3].data)["phase"] == "answer")
    assert answer[1] - answer[2] == pytest.approx(4e6, abs=2)  # published when the request went out
    arm = by_topic[f"{w.FRAMES}/arm_sdk"][0]
    assert len(arm.name) == 17 and arm.name[0] == "waist_yaw_joint" and list(arm.kp) == [60.0] * 17
    damping = by_topic[f"{w.FRAMES}/lowcmd"][0]
    assert len(damping.name) == 29 and max(damping.kp) == 0.0 and min(damping.kd) > 0.0
    verdicts = [json.loads(m.data) for m in by_topic[f"{w.BODY}/verdicts"]]
    assert verdicts[0]["tilt"] == "ok" and verdicts[1]["tilt"] == "tripping"


def test_the_files_metadata_says_what_it_is(tmp_path: Path) -> None:
    path = tmp_path / "incident.mcap"
    w.write_incident(path, [], {"cause": "~/snapshot", "mode": "IDLE"}, to_unix=lambda t: t)
    with open(path, "rb") as stream:
        metadata = {m.name: m.metadata for m in make_reader(stream).iter_metadata()}
    assert metadata == {"incident": {"cause": "~/snapshot", "mode": "IDLE"}}


def _definition(package: str, name: str) -> list[str]:
    """An installed interface file's lines without comments and blank lines, its spacing collapsed."""
    text = (Path(sys.prefix) / "share" / package / "msg" / f"{name}.msg").read_text()
    lines = (re.sub(r"\s+", " ", line.split("#", 1)[0]).strip() for line in text.splitlines())
    return [line for line in lines if line]


def test_the_embedded_schemas_are_the_installed_interface_files() -> None:
    for full_name, text in ros2_schemas.ALL:
        sections = text.split("=" * 80)
        package, _, name = full_name.split("/")
        assert [line.strip() for line in sections[0].splitlines() if line.strip()] == _definition(package, name)
        for section in sections[1:]:
            lines = [line.strip() for line in section.splitlines() if line.strip()]
            dep_package, dep_name = lines[0].removeprefix("MSG: ").split("/")
            assert lines[1:] == _definition(dep_package, dep_name), f"{full_name}'s {dep_package}/{dep_name}"
