"""The real node (rclpy, DDS on loopback) over the fake robot port: services, bad input, e-stop priority.

End-to-end behaviour against the simulated G1 is in test/e2e; here the robot is a fake so that
faults (a SelectMode held for seconds) are exact and the tests are fast.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest
import rclpy
from g1_mode_manager_msgs.msg import Mode
from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from geometry_msgs.msg import Twist
from rclpy.executors import MultiThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from fakes.fake_robot import RELEASED
from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.node.mode_manager import ModeManagerNode
from g1_mode_manager.topic_qos import MODE_QOS
from support.mode_manager import wait_until


class Harness:
    def __init__(self, port: FakeRobotPort, **params: object) -> None:
        self.port = port
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        params.setdefault("low_level_path", "release")  # the tests of this harness are about the release path
        overrides = [Parameter(k, value=v) for k, v in params.items()]
        self.node = ModeManagerNode(port_factory=lambda _s: port, context=self.context, parameter_overrides=overrides)
        self.client = rclpy.create_node("test_client", context=self.context)
        self.executor = MultiThreadedExecutor(num_threads=4, context=self.context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.client)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def call(self, srv_type, name: str, request, timeout_s: float = 20.0):
        cli = self.client.create_client(srv_type, name)
        assert cli.wait_for_service(timeout_sec=10.0), f"{name} not available"
        future = cli.call_async(request)
        done = threading.Event()
        future.add_done_callback(lambda _f: done.set())
        assert done.wait(timeout_s), f"{name} did not answer"
        return future.result()

    def set_mode(self, name: str = "", number: int = 0) -> SetMode.Response:
        return self.call(SetMode, "/g1_mode_manager/set_mode", SetMode.Request(mode=number, mode_name=name))

    def close(self) -> None:
        self.executor.shutdown()
        self.thread.join(5.0)
        self.node.shutdown()
        self.node.destroy_node()
        self.client.destroy_node()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture
def harness():
    h = Harness(FakeRobotPort())
    yield h
    h.close()




@pytest.mark.parametrize(
    ("name", "number", "needle"),
    [("warp_speed", 0, "unknown mode name 'warp_speed'"), ("", 42, "unknown mode number 42"),
     ("", 0, "no mode given"), ("uninitialized", 0, "")],
)
def test_bad_mode_requests_get_clear_errors_and_change_nothing(harness, name, number, needle) -> None:
    r = harness.set_mode(name, number)
    assert not r.success and needle in r.message and r.message
    assert r.mode == Mode.UNINITIALIZED and r.mode_name == "UNINITIALIZED"
    assert all(c.name == "connect" for c in harness.port.calls)  # no mode service was touched


def test_set_mode_by_name_case_insensitive_and_mode_is_latched(harness) -> None:
    r = harness.set_mode("High_Level")
    assert r.success and r.mode == Mode.HIGH_LEVEL, r.message
    got: list[Mode] = []
    harness.client.create_subscription(Mode, "/g1_mode_manager/mode", got.append, MODE_QOS)  # joins late
    assert wait_until(lambda: any(m.mode == Mode.HIGH_LEVEL for m in got))
    assert got[-1].name == "HIGH_LEVEL" and got[-1].high_level_service_active


@pytest.mark.parametrize("path", ["release", "user_ctrl"])
def test_mode_says_which_way_low_level_takes_in_every_mode(path: str) -> None:
    h = Harness(FakeRobotPort(), low_level_path=path)
    try:
        got: list[Mode] = []
        h.client.create_subscription(Mode, "/g1_mode_manager/mode", got.append, MODE_QOS)
        assert wait_until(lambda: bool(got)) and got[-1].name == "UNINITIALIZED"
        assert h.set_mode("idle").success
        assert wait_until(lambda: got[-1].name == "IDLE")
        assert {m.low_level_path for m in got} == {path}
        assert not any("low_level_path" in w for m in got for w in m.warnings)  # a field of its own, not a warning
    finally:
        h.close()


def test_cmd_vel_reaches_the_port_only_in_high_level(harness) -> None:
    pub = harness.client.create_publisher(Twist, "/cmd_vel", 10)
    msg = Twist()
    msg.linear.x = 0.5
    assert wait_until(lambda: pub.get_subscription_count() >= 1)
    harness.set_mode("idle")
    for _ in range(10):
        pub.publish(msg)
        time.sleep(0.02)
    assert harness.port.stream("set_velocity") == []
    harness.set_mode("high_level")
    assert wait_until(lambda: (pub.publish(msg) or True) and len(harness.port.stream("set_velocity")) >= 3)
    assert harness.port.stream("set_velocity")[-1].args[0] > 0.0


def test_estop_fires_damp_at_once_while_a_select_is_held_and_answers_after_it_landed(harness) -> None:
    harness.port.set_service(RELEASED)
    hold = harness.port.hold("select_mode", timeout_s=10.0)
    with ThreadPoolExecutor(2) as pool:
        pending = pool.submit(harness.set_mode, "high_level")
        assert hold.wait_entered(10.0)
        estop = pool.submit(harness.call, Trigger, "/g1_mode_manager/estop", Trigger.Request(), 20.0)
        # the DampNoReply goes out while the transition is still blocked inside the robot ...
        assert wait_until(lambda: "damp_no_reply" in harness.port.names(), 5.0)
        # ... but success is claimed only once that in-flight SelectMode has landed and the robot is seen damped
        time.sleep(0.3)
        assert not estop.done()
        hold.release()
        r, e = pending.result(20.0), estop.result(20.0)
    assert e.success and "robot damped (verified" in e.message, e.message
    assert harness.port.damped and harness.port.service
    assert not r.success and r.mode == Mode.EMERGENCY
    assert harness.node.machine.mode.name == "EMERGENCY"


def test_supervision_redamps_a_robot_taken_out_of_damping_after_the_estop(harness) -> None:
    assert harness.call(Trigger, "/g1_mode_manager/estop", Trigger.Request()).success
    damps = harness.port.names().count("damp")
    harness.port.undamp()  # another program stands the robot up: rt/sportmodestate now says fsm 4
    assert wait_until(lambda: harness.port.damped, 3.0)
    assert harness.port.names().count("damp") > damps
    assert wait_until(lambda: harness.node.machine.status().reasserts >= 1 and harness.node.machine.status().damp_confirmed)


def test_after_emergency_every_set_mode_is_refused_and_late_subscriber_sees_it(harness) -> None:
    assert harness.call(Trigger, "/g1_mode_manager/estop", Trigger.Request()).success
    for name in ("idle", "high_level", "low_level"):
        r = harness.set_mode(name)
        assert not r.success and r.mode == Mode.EMERGENCY
    got: list[Mode] = []
    harness.client.create_subscription(Mode, "/g1_mode_manager/mode", got.append, MODE_QOS)
    assert wait_until(lambda: bool(got)) and got[-1].name == "EMERGENCY" and got[-1].damp_confirmed


def test_estop_topic_triggers_emergency(harness) -> None:
    from std_msgs.msg import Bool

    pub = harness.client.create_publisher(Bool, "/estop", 10)
    assert wait_until(lambda: pub.get_subscription_count() >= 1)
    pub.publish(Bool(data=False))
    time.sleep(0.2)
    assert harness.node.machine.mode.name == "UNINITIALIZED"
    pub.publish(Bool(data=True))
    assert wait_until(lambda: harness.node.machine.mode.name == "EMERGENCY")


def test_service_flood_from_several_clients_keeps_node_up(harness) -> None:
    names = ["high_level", "idle", "bogus", "low_level", "HIGH_LEVEL", ""] * 5
    with ThreadPoolExecutor(6) as pool:
        results = list(pool.map(harness.set_mode, names))
    assert len(results) == len(names)
    assert all(r.message for r in results)  # every answer says what happened
    assert any("unknown mode name 'bogus'" in r.message for r in results)
    assert harness.set_mode("idle").mode_name in ("IDLE",)


def test_loco_commands_refused_outside_high_level_and_while_dynamic(harness) -> None:
    def loco(cmd: str, value: int = 0) -> LocoCommand.Response:
        return harness.call(LocoCommand, "/g1_mode_manager/loco_command", LocoCommand.Request(command=cmd, value=value))

    assert "UNINITIALIZED" in loco("stand_up").message
    harness.set_mode("idle")
    r = loco("start")
    assert not r.success and "only in HIGH_LEVEL" in r.message
    assert loco("damp").success  # damping is always allowed while the service can answer
    harness.set_mode("high_level")
    assert loco("start").success
    assert harness.port.stream("set_fsm_id")[-1].args == (500,)
    assert "unknown command" in loco("fly").message
    assert "value from 0 to 3" in loco("speed_mode", 9).message
    from g1_mode_manager.core.port import SportState

    harness.port.sport = SportState(500, 1, 0, 0.0, 0.01)
    r = loco("sit")
    assert not r.success and "dynamic" in r.message
    assert loco("damp").success


def test_estop_service_retries_a_failed_damp_by_itself(harness) -> None:
    assert harness.set_mode("high_level").success
    harness.port.fail("damp", times=2)  # the first two Damps time out
    r = harness.call(Trigger, "/g1_mode_manager/estop", Trigger.Request())
    assert r.success, r.message
    assert [c.ok for c in harness.port.calls if c.name == "damp"][-1]
    assert sum(1 for c in harness.port.calls if c.name == "damp") >= 3


def test_estop_reports_failure_when_damp_keeps_failing_and_supervision_damps_later() -> None:
    h = Harness(FakeRobotPort(), estop_timeout_s=0.5)
    try:
        assert h.set_mode("high_level").success
        h.port.fail("damp", times=100_000)
        r = h.call(Trigger, "/g1_mode_manager/estop", Trigger.Request())
        assert not r.success and "e-stop incomplete" in r.message and "supervision keeps trying" in r.message
        assert h.node.machine.mode.name == "EMERGENCY" and not h.node.machine.status().damp_confirmed
        h.port.clear_faults()  # the fault clears: supervision gets the robot damped without another request
        assert wait_until(lambda: h.port.damped and h.node.machine.status().damp_confirmed, 5.0)
    finally:
        h.close()


def test_estop_topic_reaches_the_node_from_a_best_effort_publisher(harness) -> None:
    from std_msgs.msg import Bool

    pub = harness.client.create_publisher(Bool, "/estop", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    assert harness.set_mode("high_level").success
    assert wait_until(lambda: pub.get_subscription_count() >= 1)
    assert wait_until(lambda: (pub.publish(Bool(data=True)) or True) and harness.node.machine.is_emergency(), 5.0)
    assert wait_until(lambda: harness.port.damped and harness.node.machine.status().damp_confirmed, 5.0)


def test_loco_refusals_say_nothing_was_sent(harness) -> None:
    r = harness.call(LocoCommand, "/g1_mode_manager/loco_command", LocoCommand.Request(command="start"))
    assert not r.success and r.code == -1
    assert harness.port.stream("set_fsm_id") == []
