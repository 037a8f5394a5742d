"""The bridge's ROS 2 side: parameters (faults and the gantry at run time), joint_states, ~/odom and /clock.

The ground truth odometry is the sim node's own (``~/odom``: ``/g1_sim_bridge/odom``): a plain ``odom`` would
be taken for the robot's, which the mode manager publishes from the robot's estimate (rt/odommodestate).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from g1_mode_manager.protocol.motors import JOINT_NAMES

NODE_NAME = "g1_sim_bridge"
ODOM_FRAME = "odom"
BASE_FRAME = "pelvis"


@dataclass(frozen=True)
class BridgeParams:
    network_interface: str
    dds_domain: int
    speed: float
    faults: str
    publish_ros: bool
    gantry: bool


_DESCRIPTIONS = {
    "network_interface": "Network interface of the Unitree SDK2 DDS domain ('lo' = loopback only, no multicast).",
    "dds_domain": "Cyclone DDS domain id of the Unitree SDK2 topics and RPC services.",
    "speed": "Sim time per wall time: 1 = real time, 3 = three times faster, 0 = as fast as possible.",
    "faults": "Faults to inject, JSON: delay_s {api: s}, drop [api], error {api: code}, pause_state, damp_fails, "
              "motor_temperature {motor: [casing, winding]}, battery_soc, remote_keys [key], push {force, direction, "
              "duration}, freeze_lowstate, freeze_odom, ignore_fsm_ids [fsm], odom_drift {xy_per_m, xy_mps, yaw_per_rad}, "
              "odom_noise_m, user_ctrl (none|from_damp|from_walkrun|either), user_ctrl_delay_s (docs/sim.md).",
    "publish_ros": "Publish joint_states, ~/odom (ground truth) and /clock (stamps in sim time from the start's wall time).",
    "gantry": "Hang the pelvis from a gantry's elastic band (a limp robot hangs instead of falling).",
}
_READ_ONLY = frozenset({"network_interface", "dds_domain"})


def _quat_rotate_inverse(q_wxyz: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v (world frame) expressed in the body frame of orientation q."""
    w, x, y, z = q_wxyz
    rot = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])
    return rot.T @ np.asarray(v)


def _time(stamp_ns: int) -> Time:
    return Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)


class BridgeNode(Node):
    """Parameters are declared up front; run-time changes go through ``on_faults`` / ``on_speed``."""

    def __init__(self, *, overrides: dict[str, object] | None = None, context: Context | None = None) -> None:
        super().__init__(NODE_NAME, context=context,
                         parameter_overrides=[Parameter(k, value=v) for k, v in (overrides or {}).items()])
        defaults: dict[str, object] = {"network_interface": "lo", "dds_domain": 0, "speed": 1.0, "faults": "",
                                       "publish_ros": True, "gantry": False}
        for name, default in defaults.items():
            self.declare_parameter(name, default, ParameterDescriptor(description=_DESCRIPTIONS[name],
                                                                      read_only=name in _READ_ONLY))
        self.publish_ros = bool(self.get_parameter("publish_ros").value)
        self.on_faults: Callable[[str], None] | None = None
        self.on_speed: Callable[[float], None] | None = None
        self.on_gantry: Callable[[bool], None] | None = None
        self._recording_only = threading.local()  # set while the sim itself writes a value it already acted on
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # relative: a sim launched in a namespace (one per robot) has its own; /clock stays global (ROS convention).
        # The truth is private to the sim node (~/odom), so it never passes for the robot's estimate.
        self._joint_pub = self.create_publisher(JointState, "joint_states", 10)
        self._odom_pub = self.create_publisher(Odometry, "~/odom", 10)
        self._clock_pub = self.create_publisher(Clock, "/clock", 10)
        self._joint_msg = JointState(name=list(JOINT_NAMES))
        self._odom_msg = Odometry()
        self._odom_msg.header.frame_id = ODOM_FRAME
        self._odom_msg.child_frame_id = BASE_FRAME

    def params(self) -> BridgeParams:
        g = self.get_parameter
        speed = float(g("speed").value)
        return BridgeParams(
            network_interface=str(g("network_interface").value),
            dds_domain=int(g("dds_domain").value),
            speed=speed,
            faults=str(g("faults").value),
            publish_ros=bool(g("publish_ros").value),
            gantry=bool(g("gantry").value),
        )

    def faults_cleared(self) -> None:
        """The sim's reset cleared the faults: the parameter says so too (``ros2 param get`` must not show the
        faults of before the reset, and a client setting them again must not be taken for no change)."""
        self._recording_only.on = True
        try:
            self.set_parameters([Parameter("faults", value="")])
        finally:
            self._recording_only.on = False

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        # Validate everything first, so a refused batch changes nothing.
        for p in params:
            if p.name == "speed":
                if p.type_ not in (Parameter.Type.DOUBLE, Parameter.Type.INTEGER) or float(p.value) < 0:
                    return SetParametersResult(successful=False, reason="speed must be a number >= 0")
            elif p.name == "faults" and p.type_ != Parameter.Type.STRING:
                return SetParametersResult(successful=False, reason="faults must be a JSON string")
            elif p.name in ("publish_ros", "gantry") and p.type_ != Parameter.Type.BOOL:
                return SetParametersResult(successful=False, reason=f"{p.name} must be true or false")
        if getattr(self._recording_only, "on", False):
            return SetParametersResult(successful=True)
        for p in params:
            if p.name == "faults" and self.on_faults is not None:
                try:
                    self.on_faults(p.value)
                except ValueError as e:
                    self.get_logger().error(f"faults refused, previous faults kept: {e}")
                    return SetParametersResult(successful=False, reason=str(e))
                self.get_logger().info(f"faults set: {p.value or '{}'}")
            elif p.name == "publish_ros":
                self.publish_ros = bool(p.value)
            elif p.name == "gantry" and self.on_gantry is not None:
                self.on_gantry(bool(p.value))
                self.get_logger().info(f"gantry {'on' if p.value else 'off'}")
            elif p.name == "speed" and self.on_speed is not None:
                self.on_speed(float(p.value))
                self.get_logger().info(f"speed set to {float(p.value)}")
        return SetParametersResult(successful=True)

    def publish_state(self, stamp_ns: int, q: np.ndarray, dq: np.ndarray, tau: np.ndarray,
                      position: np.ndarray, quat_wxyz: np.ndarray, lin_vel_world: np.ndarray,
                      ang_vel_world: np.ndarray) -> None:
        """Publish /clock, joint_states and ~/odom (the truth; twist in the pelvis frame, as REP 105 wants), each
        only while something subscribes: a message nobody takes is dropped by the middleware anyway, and filling
        and serialising the three at 50 Hz was a good part of an idle sim's CPU."""
        stamp = _time(stamp_ns)
        if self._clock_pub.get_subscription_count():
            self._clock_pub.publish(Clock(clock=stamp))
        if self._joint_pub.get_subscription_count():
            j = self._joint_msg
            j.header.stamp = stamp
            j.position = q.tolist()
            j.velocity = dq.tolist()
            j.effort = tau.tolist()
            self._joint_pub.publish(j)
        if not self._odom_pub.get_subscription_count():
            return
        o = self._odom_msg
        o.header.stamp = stamp
        pose = o.pose.pose
        pose.position.x, pose.position.y, pose.position.z = (float(v) for v in position)
        w, x, y, z = (float(v) for v in quat_wxyz)
        pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z = w, x, y, z
        lin = _quat_rotate_inverse(quat_wxyz, lin_vel_world)
        ang = _quat_rotate_inverse(quat_wxyz, ang_vel_world)
        twist = o.twist.twist
        twist.linear.x, twist.linear.y, twist.linear.z = (float(v) for v in lin)
        twist.angular.x, twist.angular.y, twist.angular.z = (float(v) for v in ang)
        self._odom_pub.publish(o)
