"""The console's ROS side: the mode manager's public topics feed the RobotView, its services are called for the
pages, and cmd_vel is published on the mode manager's own topic, so its clamps, ramps and watchdog apply. The
Policy card's topics and services are policy_card.py's; their calls go through the same ``call``.

Service calls never wait in a thread: each answer comes back to the web server's event loop. The mode
manager's parameters that the page needs (the head LED looks, whether cmd_vel is stamped, its watchdog time)
are read once through its get_parameters service, retried until the node answers; its incident folder
(recorder_dir) then, in a request of its own.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from g1_mode_manager_msgs.msg import Mode as ModeMsg
from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from geometry_msgs.msg import Twist, TwistStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Imu
from std_srvs.srv import Trigger

from g1_mode_manager.console.policy_card import PolicyFeed
from g1_mode_manager.console.policy_view import PolicyView
from g1_mode_manager.console.robot_view import AUTONOMY_LOOK, DiagStatus, RobotView, mode_fields
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.display.head_led import LedLook
from g1_mode_manager.topic_qos import MODE_QOS

Velocity = tuple[float, float, float]
#: The head LED looks the console reads: each mode's (head_led_<mode>), and the autonomy's (HIGH_LEVEL while it drives).
LED_PARAMS = {**{m.name: f"head_led_{m.name.lower()}" for m in Mode}, AUTONOMY_LOOK: "head_led_autonomy"}
#: Parameters of the mode manager the console reads.
NODE_PARAMS = ("cmd_vel_stamped", "cmd_vel_timeout_s", *LED_PARAMS.values())
#: Read apart, once NODE_PARAMS are: a node that lacks one parameter of a request answers none of them.
RECORDER_DIR = "recorder_dir"


class ServiceUnavailableError(RuntimeError):
    """The mode manager's service is not in the graph."""


def _value(p: Any) -> Any:
    return {ParameterType.PARAMETER_BOOL: p.bool_value, ParameterType.PARAMETER_DOUBLE: p.double_value,
            ParameterType.PARAMETER_INTEGER: p.integer_value,
            ParameterType.PARAMETER_STRING: p.string_value}.get(p.type)


class RosBridge:
    def __init__(self, node: Node, manager: str, view: RobotView, policy_view: PolicyView,
                 on_change: Callable[[], None]) -> None:
        self.node = node
        self.manager = manager
        self._view = view
        self._on_change = on_change
        self._namespace = manager.rpartition("/")[0]
        self.cmd_vel_topic = f"{self._namespace}/cmd_vel"
        self._lock = threading.Lock()
        self._cmd_vel: Any = None  # made once the node's parameters say Twist or TwistStamped
        self._stamped = False
        self.node_params: dict[str, Any] = {}
        self.node_recorder_dir: str | None = None  # the mode manager's recorder_dir, once read
        self._last_mode_key: tuple | None = None
        self._latest_mode: tuple[str, str] | None = None
        node.create_subscription(ModeMsg, f"{manager}/mode", self._on_mode, MODE_QOS)
        node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        # best effort matches both reliable and best-effort publishers
        node.create_subscription(Odometry, f"{self._namespace}/odom", self._on_odom, qos_profile_sensor_data)
        node.create_subscription(Imu, f"{manager}/imu", self._on_imu, qos_profile_sensor_data)
        self._clients = {"set_mode": node.create_client(SetMode, f"{manager}/set_mode"),
                         "loco": node.create_client(LocoCommand, f"{manager}/loco_command"),
                         "estop": node.create_client(Trigger, f"{manager}/estop"),
                         "clear_fault": node.create_client(Trigger, f"{manager}/clear_fault"),
                         "hand_over": node.create_client(Trigger, f"{manager}/hand_over_to_autonomy"),
                         "take_over": node.create_client(Trigger, f"{manager}/take_over")}
        self.policy = PolicyFeed(node, manager, self._namespace, policy_view, on_change)
        self._clients.update(self.policy.clients)
        self._params_client = node.create_client(GetParameters, f"{manager}/get_parameters")
        self._params_pending = False
        self._params_timer = node.create_timer(0.25, self._read_node_params)  # until the node answers

    # --- state in ------------------------------------------------------------------------------------
    def latest_mode(self) -> tuple[str, str] | None:
        """The latest ~/mode's name and the robot's posture in it, or None before the first (any thread)."""
        return self._latest_mode

    def _on_mode(self, msg: ModeMsg) -> None:
        self._latest_mode = (msg.name, msg.posture)
        fields = mode_fields(msg)
        self._view.on_mode(fields, time.monotonic())
        key = (fields["name"], fields["transition_in_progress"], fields["damp_confirmed"], fields["last_refusal"],
               tuple(fields["faults"]), tuple(fields["holds"]), fields["link_ok"], fields["driver"],
               fields["autonomy_suspended"])
        if key != self._last_mode_key:
            self._last_mode_key = key
            self._on_change()

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        mine = [DiagStatus(s.name, int.from_bytes(s.level, "little") if isinstance(s.level, bytes) else int(s.level),
                           s.message, {kv.key: kv.value for kv in s.values})
                for s in msg.status if s.hardware_id == self.manager]
        if mine:
            self._view.on_diagnostics(mine, time.monotonic())

    def _on_odom(self, msg: Odometry) -> None:
        o, v = msg.pose.pose.orientation, msg.twist.twist.linear
        self._view.on_odom(v.x, v.y, (o.w, o.x, o.y, o.z), time.monotonic())

    def _on_imu(self, msg: Imu) -> None:
        o = msg.orientation
        self._view.on_imu((o.w, o.x, o.y, o.z), time.monotonic())

    def _read_node_params(self) -> None:
        if self._params_pending or not self._params_client.service_is_ready():
            return
        self._params_pending = True
        future = self._params_client.call_async(GetParameters.Request(names=list(NODE_PARAMS)))
        future.add_done_callback(self._took_node_params)

    def _took_node_params(self, future: Any) -> None:
        self._params_pending = False
        result = future.result()
        if result is None or len(result.values) != len(NODE_PARAMS):
            return
        params = {name: _value(v) for name, v in zip(NODE_PARAMS, result.values, strict=True)}
        looks = {}
        for key, name in LED_PARAMS.items():
            text = params.get(name)
            try:
                looks[key] = LedLook.parse(text) if text else None
            except ValueError:
                looks[key] = None
        self._view.set_looks({k: v for k, v in looks.items() if v is not None})
        with self._lock:
            self.node_params = params
            self._stamped = bool(params.get("cmd_vel_stamped"))
            msg_type = TwistStamped if self._stamped else Twist
            self._cmd_vel = self.node.create_publisher(msg_type, self.cmd_vel_topic, 10)
        self._params_timer.cancel()
        self._params_client.call_async(GetParameters.Request(names=[RECORDER_DIR])).add_done_callback(
            self._took_recorder_dir)
        self.node.get_logger().info(f"read the mode manager's parameters: cmd_vel on {self.cmd_vel_topic} as "
                                    f"{msg_type.__name__}, watchdog {params.get('cmd_vel_timeout_s')} s")
        self._on_change()

    def _took_recorder_dir(self, future: Any) -> None:
        result = future.result()
        if result is not None and len(result.values) == 1 and result.values[0].type == ParameterType.PARAMETER_STRING:
            self.node_recorder_dir = result.values[0].string_value

    # --- commands out --------------------------------------------------------------------------------
    def ready_to_drive(self) -> str | None:
        """Why cmd_vel cannot be published yet (the node's parameters not read), or None."""
        with self._lock:
            return None if self._cmd_vel is not None else "the mode manager's parameters are not read yet"

    def publish(self, v: Velocity) -> bool:
        with self._lock:
            pub, stamped = self._cmd_vel, self._stamped
        if pub is None:
            return False
        if stamped:
            msg = TwistStamped()
            msg.header.stamp = self.node.get_clock().now().to_msg()
            twist = msg.twist
        else:
            msg = twist = Twist()
        twist.linear.x, twist.linear.y, twist.angular.z = (float(c) for c in v)
        pub.publish(msg)
        return True

    async def call(self, service: str, request: Any, timeout_s: float) -> Any:
        """Call one of the mode manager's services from the event loop; ServiceUnavailableError or TimeoutError."""
        client = self._clients[service]
        if not client.service_is_ready():
            raise ServiceUnavailableError(f"{client.srv_name} is not available: is the mode manager running?")
        loop = asyncio.get_running_loop()
        answer: asyncio.Future = loop.create_future()

        def settle(done: Any) -> None:
            if answer.done():
                return
            exc = done.exception()
            if exc is not None:
                answer.set_exception(exc)
            else:
                answer.set_result(done.result())

        future = client.call_async(request)
        future.add_done_callback(lambda done: loop.call_soon_threadsafe(settle, done))
        return await asyncio.wait_for(answer, timeout_s)


def set_mode_request(mode: str) -> SetMode.Request:
    return SetMode.Request(mode_name=mode)


def loco_request(command: str, value: int) -> LocoCommand.Request:
    return LocoCommand.Request(command=command, value=value)


def trigger_request() -> Trigger.Request:
    return Trigger.Request()
