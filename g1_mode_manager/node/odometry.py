"""odom (nav_msgs/Odometry) and the odom -> pelvis transform, from the robot's own state estimate.

The G1 publishes its estimator's output on rt/lf/odommodestate (about 20 Hz) in high-level mode only, and
only with a recent firmware. Each sample is published once, stamped with the time it was received (the
robot's clock is not this machine's); nothing is published from a stale or missing stream, and the
odometry status on /diagnostics says why (LOW_LEVEL, old firmware, a stalled stream).

Covariances (diagonal, the robot states none): the estimate drifts with distance walked, so the pose
variance is that of a few centimetres and degrees over a typical walk, not of a single step:
x, y 0.05^2 m^2, z 0.1^2 m^2, roll and pitch 0.02^2 rad^2, yaw 0.05^2 rad^2; twist vx, vy, vz 0.05^2
(m/s)^2, angular rates 0.05^2 (rad/s)^2.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from nav_msgs.msg import Odometry
from rclpy.duration import Duration
from rclpy.node import Node

from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import OdomSample, RobotPort
from g1_mode_manager.protocol.odom_fields import rotate_into_body
from g1_mode_manager.protocol.topics import LF_ODOMMODESTATE

try:  # tf2_msgs ships with every ROS install; from PyPI wheels only as scripts/build_msgs.sh builds it
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
except ImportError:  # pragma: no cover - depends on the install
    TFMessage = None  # type: ignore[assignment,misc]

#: A sample older than this is not published (the robot's rate is 20 Hz: 10 samples missed).
STALE_S = 0.5
POSE_VARIANCE = (0.05**2, 0.05**2, 0.1**2, 0.02**2, 0.02**2, 0.05**2)
TWIST_VARIANCE = (0.05**2,) * 6


def _diagonal(values: tuple[float, ...]) -> list[float]:
    out = [0.0] * 36
    for i, v in enumerate(values):
        out[7 * i] = v
    return out


class OdometryPublisher:
    """``tick`` publishes the newest sample if it is new and fresh; ``status`` reports on /diagnostics."""

    def __init__(self, node: Node, port: RobotPort, mode: Callable[[], Mode], *, frame_id: str, child_frame_id: str,
                 publish_tf: bool, enabled: bool) -> None:
        self._node = node
        self._port = port
        self._mode = mode
        self._enabled = enabled
        self._lock = threading.Lock()
        self._last_count = 0
        self._published = 0
        self._msg = Odometry()
        self._msg.header.frame_id = frame_id
        self._msg.child_frame_id = child_frame_id
        self._msg.pose.covariance = _diagonal(POSE_VARIANCE)
        self._msg.twist.covariance = _diagonal(TWIST_VARIANCE)
        self._pub = node.create_publisher(Odometry, "odom", 10) if enabled else None
        self._tf_pub = None
        self.tf_missing = publish_tf and TFMessage is None
        if enabled and publish_tf and TFMessage is not None:
            self._tf_pub = node.create_publisher(TFMessage, "/tf", 100)
            self._tf = TransformStamped()
            self._tf.header.frame_id = frame_id
            self._tf.child_frame_id = child_frame_id

    def tick(self) -> None:
        sample = self._port.odometry()
        if self._pub is None or sample is None or sample.age_s > STALE_S:
            return
        with self._lock:
            if sample.count == self._last_count:
                return
            self._last_count = sample.count
            self._published += 1
        self._publish(sample)

    def _publish(self, sample: OdomSample) -> None:
        f, m = sample.fields, self._msg
        stamp = (self._node.get_clock().now() - Duration(nanoseconds=int(sample.age_s * 1e9))).to_msg()
        m.header.stamp = stamp
        p, o = m.pose.pose.position, m.pose.pose.orientation
        p.x, p.y, p.z = (float(c) for c in f.position)
        o.w, o.x, o.y, o.z = (float(c) for c in f.quaternion)
        lin, ang = m.twist.twist.linear, m.twist.twist.angular
        lin.x, lin.y, lin.z = rotate_into_body(f.quaternion, f.velocity)  # REP 105: twist in the child frame
        ang.x, ang.y, ang.z = float(f.gyroscope[0]), float(f.gyroscope[1]), float(f.yaw_speed)
        assert self._pub is not None
        self._pub.publish(m)
        if self._tf_pub is not None:
            t = self._tf
            t.header.stamp = stamp
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = p.x, p.y, p.z
            t.transform.rotation = o
            self._tf_pub.publish(TFMessage(transforms=[t]))

    def status(self, hardware_id: str) -> DiagnosticStatus:
        st = DiagnosticStatus(name="g1_mode_manager: odometry", hardware_id=hardware_id)
        sample = self._port.odometry()
        age = None if sample is None else sample.age_s
        st.values = [KeyValue(key="source", value=LF_ODOMMODESTATE),
                     KeyValue(key="age_s", value="" if age is None else f"{age:.3f}"),
                     KeyValue(key="published", value=str(self._published))]
        mode = self._mode()
        st.level = DiagnosticStatus.OK
        if not self._enabled:
            st.message = "off (odom_rate_hz 0)"
        elif age is not None and age <= STALE_S:
            st.message = f"publishing odom from {LF_ODOMMODESTATE}"
            if self.tf_missing:
                st.level = DiagnosticStatus.WARN
                st.message += "; no TF: tf2_msgs is not installed (run scripts/build_msgs.sh)"
        elif mode is Mode.LOW_LEVEL:
            st.level = DiagnosticStatus.WARN
            st.message = ("LOW_LEVEL: the robot's high-level services are off and so is its odometry; odom "
                          "stopped (nothing stale is published) until HIGH_LEVEL")
        elif mode in (Mode.UNINITIALIZED, Mode.EMERGENCY, Mode.FAULT):
            st.message = f"{mode.name}: no odometry expected now"
        elif sample is None:
            st.level = DiagnosticStatus.WARN
            st.message = (f"no {LF_ODOMMODESTATE} from the robot: its firmware may not publish odometry (a recent "
                          "state-estimator firmware does, in high-level mode); odom not published")
        else:
            st.level = DiagnosticStatus.WARN
            st.message = f"{LF_ODOMMODESTATE} stale ({age:.1f} s): odom paused"
        return st
