"""A small rclpy client of the mode manager's services and topics, shared by g1ctl and the demo."""

from __future__ import annotations

import os
import threading
import time

import rclpy
from g1_mode_manager_msgs.msg import Mode, PolicyStatus, SportModeState
from g1_mode_manager_msgs.srv import LoadPolicy, LocoCommand, SetMode
from geometry_msgs.msg import Twist
from rcl_interfaces.srv import GetParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from std_srvs.srv import Trigger

from g1_mode_manager.topic_qos import MODE_QOS


def default_discovery_to_localhost() -> None:
    """Like the demo, stay on this machine unless the user chose otherwise."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def call_service(node: Node, srv_type, name: str, request, timeout_s: float, discovery_timeout_s: float = 10.0):
    """Call a service from a node that another thread spins; TimeoutError if absent or silent."""
    client = node.create_client(srv_type, name)
    try:
        return call_client(client, name, request, timeout_s, discovery_timeout_s)
    finally:
        node.destroy_client(client)


def call_client(client, name: str, request, timeout_s: float, discovery_timeout_s: float = 10.0):
    """Call through an existing client (spun by another thread); TimeoutError if absent or silent."""
    if not client.wait_for_service(timeout_sec=discovery_timeout_s):
        raise TimeoutError(f"service {name} not available: is the mode manager running?")
    future = client.call_async(request)
    done = threading.Event()
    future.add_done_callback(lambda _f: done.set())
    if not done.wait(timeout_s):
        raise TimeoutError(f"{name} did not answer within {timeout_s} s")
    return future.result()


def cmd_vel_topic(manager: str) -> str:
    """The manager's cmd_vel (relative to its namespace): /g1_a/g1_mode_manager -> /g1_a/cmd_vel."""
    namespace = manager.rstrip("/").rpartition("/")[0]
    return f"{namespace}/cmd_vel"


class ManagerClient:
    """Calls ~/set_mode, ~/estop, ~/loco_command of a mode manager node and watches ~/mode."""

    def __init__(self, manager: str = "/g1_mode_manager", name: str = "g1ctl") -> None:
        self.manager = manager.rstrip("/")
        self._context = rclpy.Context()
        rclpy.init(context=self._context)
        self.node = Node(f"{name}_{os.getpid()}", context=self._context)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)
        # A waiting executor does not see entities created later until something wakes it: a no-op
        # timer wakes it every 0.1 s, so subscriptions added after the start are served too.
        self.node.create_timer(0.1, lambda: None)
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()
        self._lock = threading.Lock()
        self.last_mode: Mode | None = None
        self.last_sport: SportModeState | None = None
        self.last_policy: PolicyStatus | None = None
        self._mode_listeners: list = []
        self.node.create_subscription(Mode, f"{self.manager}/mode", self._on_mode, MODE_QOS)
        self.node.create_subscription(SportModeState, f"{self.manager}/sportmodestate", self._on_sport, 10)
        self.node.create_subscription(PolicyStatus, f"{self.manager}/policy/status", self._on_policy, MODE_QOS)
        self.cmd_vel = self.node.create_publisher(Twist, cmd_vel_topic(self.manager), 10)

    def close(self) -> None:
        self._executor.shutdown()
        self._thread.join(5.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self._context)

    def __enter__(self) -> ManagerClient:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def _on_mode(self, msg: Mode) -> None:
        with self._lock:
            self.last_mode = msg
            listeners = list(self._mode_listeners)
        for listener in listeners:
            listener(msg)

    def _on_sport(self, msg: SportModeState) -> None:
        with self._lock:
            self.last_sport = msg

    def _on_policy(self, msg: PolicyStatus) -> None:
        with self._lock:
            self.last_policy = msg

    def policy_status(self) -> PolicyStatus | None:
        """The latest ~/policy/status (2 Hz while the loop ticks, and at each change of phase), or None."""
        with self._lock:
            return self.last_policy

    def on_mode(self, listener) -> None:
        with self._lock:
            self._mode_listeners.append(listener)

    def wait_for_mode(self, timeout_s: float = 10.0) -> Mode | None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                if self.last_mode is not None:
                    return self.last_mode
            time.sleep(0.05)
        return None

    def mode(self) -> tuple[str, str] | None:
        """The latest ~/mode's name and the robot's posture in it, or None before the first (the recovery reads
        these: core/recovery.py)."""
        with self._lock:
            m = self.last_mode
        return None if m is None else (m.name, m.posture)

    def _call(self, srv_type, name: str, request, timeout_s: float):
        return call_service(self.node, srv_type, f"{self.manager}/{name}", request, timeout_s)

    def parameter(self, name: str, timeout_s: float = 2.0) -> object | None:
        """The manager's parameter ``name``; None if the manager does not answer within ``timeout_s`` (not running)."""
        try:
            reply = call_service(self.node, GetParameters, f"{self.manager}/get_parameters",
                                 GetParameters.Request(names=[name]), timeout_s, discovery_timeout_s=timeout_s)
        except TimeoutError:
            return None
        return parameter_value_to_python(reply.values[0]) if reply.values else None

    def set_mode(self, mode_name: str, timeout_s: float = 30.0) -> SetMode.Response:
        return self._call(SetMode, "set_mode", SetMode.Request(mode_name=mode_name), timeout_s)

    def estop(self, timeout_s: float = 30.0) -> Trigger.Response:
        return self._call(Trigger, "estop", Trigger.Request(), timeout_s)

    def trigger(self, name: str, timeout_s: float = 10.0) -> Trigger.Response:
        """Call one of the manager's Trigger services, e.g. hand_over_to_autonomy, take_over, clear_fault."""
        return self._call(Trigger, name, Trigger.Request(), timeout_s)

    def load_policy(self, policy: str, timeout_s: float = 30.0) -> LoadPolicy.Response:
        return self._call(LoadPolicy, "policy/load", LoadPolicy.Request(policy=policy), timeout_s)

    def loco(self, command: str, value: int = 0, timeout_s: float = 20.0) -> LocoCommand.Response:
        """The default outlasts the node's longest outcome wait (loco_get_up_timeout_s, 12 s)."""
        return self._call(LocoCommand, "loco_command", LocoCommand.Request(command=command, value=value), timeout_s)

    def drive(self, vx: float, vy: float = 0.0, wz: float = 0.0) -> None:
        msg = Twist()
        msg.linear.x, msg.linear.y, msg.angular.z = float(vx), float(vy), float(wz)
        self.cmd_vel.publish(msg)
