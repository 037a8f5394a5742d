"""The generated interfaces work in a real rclpy service round trip and pub/sub (DDS, loopback)."""

from __future__ import annotations

import threading

import pytest
import rclpy
from g1_mode_manager_msgs.msg import JointCommand, Mode, SportModeState
from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from rclpy.executors import MultiThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from support.mode_manager import wait_until


@pytest.fixture
def ros_pair():
    """Two nodes (a server side and a client side) spun by one executor thread."""
    context = rclpy.Context()
    rclpy.init(context=context)
    server = rclpy.create_node("iface_server", context=context)
    client = rclpy.create_node("iface_client", context=context)
    executor = MultiThreadedExecutor(num_threads=2, context=context)
    executor.add_node(server)
    executor.add_node(client)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    yield server, client
    executor.shutdown()
    thread.join(5.0)
    server.destroy_node()
    client.destroy_node()
    rclpy.try_shutdown(context=context)




def test_mode_constants_match_the_issue() -> None:
    assert (Mode.UNINITIALIZED, Mode.IDLE, Mode.HIGH_LEVEL, Mode.LOW_LEVEL, Mode.EMERGENCY) == (0, 1, 2, 3, 4)


def test_set_mode_service_round_trip(ros_pair) -> None:
    server, client = ros_pair
    seen: list[tuple[int, str]] = []

    def handle(request: SetMode.Request, response: SetMode.Response) -> SetMode.Response:
        seen.append((request.mode, request.mode_name))
        response.success = request.mode_name.lower() == "high_level"
        response.message = f"asked for {request.mode_name!r}"
        response.mode = Mode.HIGH_LEVEL if response.success else Mode.IDLE
        response.mode_name = "HIGH_LEVEL" if response.success else "IDLE"
        return response

    server.create_service(SetMode, "set_mode", handle)
    cli = client.create_client(SetMode, "set_mode")
    assert cli.wait_for_service(timeout_sec=10.0)
    future = cli.call_async(SetMode.Request(mode_name="high_level"))
    assert wait_until(future.done)
    result = future.result()
    assert seen == [(0, "high_level")]
    assert result.success and result.mode == Mode.HIGH_LEVEL and result.mode_name == "HIGH_LEVEL"
    assert result.message == "asked for 'high_level'"


def test_loco_command_service_round_trip(ros_pair) -> None:
    server, client = ros_pair

    def handle(request: LocoCommand.Request, response: LocoCommand.Response) -> LocoCommand.Response:
        response.success = False
        response.code = 7302
        response.message = f"{request.command}:{request.value}"
        return response

    server.create_service(LocoCommand, "loco_command", handle)
    cli = client.create_client(LocoCommand, "loco_command")
    assert cli.wait_for_service(timeout_sec=10.0)
    future = cli.call_async(LocoCommand.Request(command="speed_mode", value=3))
    assert wait_until(future.done)
    assert (future.result().code, future.result().message) == (7302, "speed_mode:3")


def test_mode_latched_for_late_subscriber_and_state_pubsub(ros_pair) -> None:
    server, client = ros_pair
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    mode_pub = server.create_publisher(Mode, "mode", latched)
    mode_pub.publish(Mode(mode=Mode.EMERGENCY, name="EMERGENCY", stamp=server.get_clock().now().to_msg()))

    got_mode: list[Mode] = []
    client.create_subscription(Mode, "mode", got_mode.append, latched)  # joins after the publish
    assert wait_until(lambda: len(got_mode) == 1)
    assert got_mode[0].mode == Mode.EMERGENCY and got_mode[0].name == "EMERGENCY"

    got_state: list[SportModeState] = []
    got_cmd: list[JointCommand] = []
    client.create_subscription(SportModeState, "sportmodestate", got_state.append, 10)
    client.create_subscription(JointCommand, "lowcmd", got_cmd.append, 10)
    state_pub = server.create_publisher(SportModeState, "sportmodestate", 10)
    cmd_pub = server.create_publisher(JointCommand, "lowcmd", 10)
    assert wait_until(lambda: state_pub.get_subscription_count() == 1 and cmd_pub.get_subscription_count() == 1)
    state_pub.publish(SportModeState(fsm_id=500, fsm_mode=1, task_id=7, task_time=1.5))
    cmd_pub.publish(JointCommand(name=["left_knee_joint"], q=[0.5], dq=[0.0], tau=[1.0], kp=[40.0], kd=[1.0]))
    assert wait_until(lambda: got_state and got_cmd)
    assert (got_state[0].fsm_id, got_state[0].fsm_mode, got_state[0].task_id) == (500, 1, 7)
    assert got_state[0].task_time == pytest.approx(1.5)
    assert list(got_cmd[0].name) == ["left_knee_joint"] and list(got_cmd[0].q) == [0.5]
