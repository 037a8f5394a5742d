"""The recording robot port: every call's request and answer on the ring with its code and latency, the e-stop's
first packet recorded only after it left, frames decimated, and the user_ctrl path kept or not as the port has it."""

from __future__ import annotations

import threading

import pytest

from fakes.fake_clock import FakeClock
from fakes.fake_robot import FakeRobot
from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.joint_commands import DAMPING
from g1_mode_manager.core.port import OdomSample, RobotError, RobotPort
from g1_mode_manager.core.recorder.events import FrameSent, OdometrySeen, Phase, RobotCall
from g1_mode_manager.core.user_ctrl import UserCtrlPort
from g1_mode_manager.flight_recorder.recording_port import RecordingPort, recording_port
from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.fsm import InternalCtrl
from g1_mode_manager.protocol.odom_fields import OdomFields


def _port(robot=None, frame_period_s: float = 0.1):
    events: list = []
    clock = FakeClock()
    robot = robot or FakeRobotPort()
    return recording_port(robot, events.append, frame_period_s=frame_period_s, clock=clock), robot, events, clock


def test_a_call_is_recorded_as_its_request_and_its_answer() -> None:
    port, robot, events, _ = _port()
    port.connect()
    assert port.check_mode() == "ai"
    port.select_mode("ai", timeout_s=2.0)
    robot.fail("damp", api_ids.ERR_CLIENT_API_TIMEOUT)
    with pytest.raises(RobotError):
        port.damp()
    calls = [(e.verb.name, e.phase, e.args, e.code) for e in events]
    assert calls == [("Connect", Phase.REQUEST, (), 0), ("Connect", Phase.ANSWER, (), 0),
                     ("CheckMode", Phase.REQUEST, (), 0), ("CheckMode", Phase.ANSWER, (), 0),
                     ("SelectMode", Phase.REQUEST, ("ai",), 0), ("SelectMode", Phase.ANSWER, ("ai",), 0),
                     ("Damp", Phase.REQUEST, (), 0), ("Damp", Phase.ANSWER, (), api_ids.ERR_CLIENT_API_TIMEOUT)]
    assert events[3].answer == "ai" and events[3].latency_s == 0.0  # the fake clock stood still
    assert "timeout" in events[-1].error
    assert [e.call_id for e in events[6:]] == [events[6].call_id] * 2
    assert [c.name for c in robot.calls] == ["connect", "check_mode", "select_mode", "damp"]


def test_the_estops_first_packet_is_recorded_after_it_left() -> None:
    port, robot, events, _ = _port()
    robot.connect()
    seen_at_send: list[int] = []
    inner = robot.damp_no_reply
    robot.damp_no_reply = lambda: (seen_at_send.append(len(events)), inner())[1]  # type: ignore[method-assign]
    port.damp_no_reply()
    assert seen_at_send == [0]  # nothing was recorded in front of it
    assert [(e.verb.name, e.phase) for e in events] == [("DampNoReply", Phase.NO_REPLY)]


def test_a_moves_answer_is_recorded_when_its_reply_is_waited_for() -> None:
    port, robot, events, clock = _port()
    hold = robot.move_reply_hold = threading.Event()
    reply = port.send_velocity(0.3, 0.0, 0.1, 1.0)
    assert [(e.verb.name, e.phase, e.args) for e in events] == [("SetVelocity", Phase.REQUEST, (0.3, 0.0, 0.1, 1.0))]
    clock.advance(0.004)
    hold.set()
    reply.wait()
    assert events[-1].phase is Phase.ANSWER and events[-1].latency_s == pytest.approx(0.004)
    robot.move_reply_hold = None
    robot.fail_stream["set_velocity"] = api_ids.ERR_CLIENT_API_TIMEOUT
    reply = port.send_velocity(0.3, 0.0, 0.0, 1.0)
    with pytest.raises(RobotError):
        reply.wait()
    assert events[-1].phase is Phase.ANSWER and events[-1].code == api_ids.ERR_CLIENT_API_TIMEOUT


def test_frames_are_kept_at_most_once_a_period_per_topic() -> None:
    port, robot, events, clock = _port(frame_period_s=0.1)
    for _ in range(50):  # 500 Hz for 0.1 s
        port.write_lowcmd(DAMPING)
        port.write_user_lowcmd(DAMPING)
        clock.advance(0.002)
    clock.advance(0.001)
    port.write_lowcmd(DAMPING)
    frames = [e for e in events if isinstance(e, FrameSent)]
    assert [f.topic for f in frames] == ["lowcmd", "user_lowcmd", "lowcmd"]
    assert len(frames[0].values) == 29 * 5 and max(frames[0].values[3::5]) == 0.0  # kp 0: damping
    assert len(robot.stream("write_lowcmd")) == 51  # every frame went to the robot


def test_each_odometry_sample_is_kept_once_however_often_it_is_read() -> None:
    port, robot, events, _ = _port()
    assert port.odometry() is None and events == []  # none yet: nothing kept
    fields = OdomFields(stamp_s=1.0, position=(0.0, 0.0, 0.75), velocity=(0.4, 0.0, 0.0), yaw_speed=0.2,
                        quaternion=(1.0, 0.0, 0.0, 0.0), gyroscope=(0.0, 0.0, 0.2), rpy=(0.0, 0.0, 0.0),
                        body_height=0.75)
    for count in (1, 1, 2, 2, 2, 1, 3):  # read by several parts; a slow reader's older sample comes last but one
        robot.odom = OdomSample(fields, 0.01, count)
        assert port.odometry() is robot.odom  # passed on unchanged
    kept = [e for e in events if isinstance(e, OdometrySeen)]
    assert len(kept) == 3 and len(events) == 3
    assert (kept[0].velocity, kept[0].yaw_speed, kept[0].quaternion) == (fields.velocity, 0.2, fields.quaternion)


def test_the_user_ctrl_path_is_there_exactly_when_the_port_has_it() -> None:
    port, robot, events, _ = _port()
    robot.connect()
    assert isinstance(port, UserCtrlPort) and isinstance(port, RobotPort)
    port.switch_to_internal_ctrl(InternalCtrl.WALKRUN)
    assert isinstance(events[-1], RobotCall) and events[-1].args == (int(InternalCtrl.WALKRUN),)
    plain, *_ = _port(robot=FakeRobot())
    assert type(plain) is RecordingPort and not isinstance(plain, UserCtrlPort)
