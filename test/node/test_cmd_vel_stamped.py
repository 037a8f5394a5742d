"""cmd_vel as geometry_msgs/TwistStamped (cmd_vel_stamped: true): fresh stamps reach the robot, stale ones
are dropped and counted in /diagnostics; the plain Twist subscription is then absent."""

from __future__ import annotations

import threading
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from g1_mode_manager_msgs.srv import SetMode
from geometry_msgs.msg import TwistStamped
from rclpy.duration import Duration
from rclpy.executors import MultiThreadedExecutor
from rclpy.parameter import Parameter

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.node.mode_manager import ModeManagerNode
from support.mode_manager import wait_until


def test_fresh_stamped_commands_pass_and_stale_ones_are_dropped_and_counted() -> None:
    port = FakeRobotPort()
    context = rclpy.Context()
    rclpy.init(context=context)
    node = ModeManagerNode(port_factory=lambda _s: port, context=context,
                           parameter_overrides=[Parameter("cmd_vel_stamped", value=True),
                                                Parameter("cmd_vel_timeout_s", value=0.5),
                                                Parameter("diagnostics_rate_hz", value=10.0)])
    client = rclpy.create_node("stamped_client", context=context)
    executor = MultiThreadedExecutor(num_threads=4, context=context)
    executor.add_node(node)
    executor.add_node(client)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    try:
        diags: list[DiagnosticArray] = []
        client.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
        pub = client.create_publisher(TwistStamped, "/cmd_vel", 10)
        assert wait_until(lambda: pub.get_subscription_count() >= 1)
        assert client.count_subscribers("/cmd_vel") == 1  # only the stamped one: types never mix on a topic
        types = dict(client.get_topic_names_and_types())
        assert types["/cmd_vel"] == ["geometry_msgs/msg/TwistStamped"]
        cli = client.create_client(SetMode, "/g1_mode_manager/set_mode")
        assert cli.wait_for_service(timeout_sec=10.0)
        future = cli.call_async(SetMode.Request(mode_name="high_level"))
        assert wait_until(future.done, 10.0) and future.result().success

        def send(age_s: float, vx: float) -> None:
            msg = TwistStamped()
            msg.header.stamp = (client.get_clock().now() - Duration(seconds=age_s)).to_msg()
            msg.twist.linear.x = vx
            pub.publish(msg)

        for _ in range(10):
            send(2.0, 0.7)  # stale: older than cmd_vel_timeout_s
            time.sleep(0.02)
        assert wait_until(lambda: _counter(diags, "cmd_vel_stale_dropped") >= 10, 5.0), _counter(diags, "cmd_vel_stale_dropped")
        assert [s for s in port.stream("set_velocity") if s.args[0] > 0] == []
        assert wait_until(lambda: (send(0.01, 0.5) or True) and any(s.args[0] > 0 for s in port.stream("set_velocity")))
        unstamped = TwistStamped()
        unstamped.twist.linear.x = 0.7
        before = _counter(diags, "cmd_vel_stale_dropped")
        pub.publish(unstamped)  # stamp 0: cannot prove it is fresh
        assert wait_until(lambda: _counter(diags, "cmd_vel_stale_dropped") == before + 1, 5.0)
    finally:
        executor.shutdown()
        thread.join(5.0)
        node.shutdown()
        node.destroy_node()
        client.destroy_node()
        rclpy.try_shutdown(context=context)


def _counter(diags: list[DiagnosticArray], key: str) -> int:
    for array in reversed(diags):
        for status in array.status:
            for kv in status.values:
                if kv.key == key:
                    return int(kv.value)
    return 0

