"""joint_states (sensor_msgs/JointState) and ~/imu (sensor_msgs/Imu) from the robot's rt/lowstate.

A timer at ``joint_state_rate_hz`` takes the raw bytes of the latest rt/lowstate and decodes them only
then, so the 500 Hz stream costs nothing between publications; a sample already published is not
published again (a silent robot publishes nothing rather than stale joint states).
"""

from __future__ import annotations

from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState

from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.protocol.lowstate_fields import decode_fields
from g1_mode_manager.protocol.motors import JOINT_NAMES

#: frame_id of ~/imu: the G1's IMU sits in the pelvis (the Menagerie model's imu site is there too).
IMU_FRAME = "imu_link"


class LowStatePublisher:
    """Publishes ``joint_states`` (relative: a namespace gives each robot its own) and ``~/imu``."""

    def __init__(self, node: Node, port: RobotPort) -> None:
        self._node = node
        self._port = port
        self._joints = node.create_publisher(JointState, "joint_states", 10)
        self._imu = node.create_publisher(Imu, "~/imu", 10)
        self._joint_msg = JointState(name=list(JOINT_NAMES))
        self._imu_msg = Imu()
        self._imu_msg.header.frame_id = IMU_FRAME
        self._last_count = -1

    def publish(self) -> None:
        latest = self._port.lowstate_data()
        if latest is None:
            return
        data, count = latest
        if count == self._last_count:
            return
        self._last_count = count
        fields = decode_fields(data)
        stamp = self._node.get_clock().now().to_msg()
        j = self._joint_msg
        j.header.stamp = stamp
        j.position, j.velocity, j.effort = list(fields.q), list(fields.dq), list(fields.tau)
        self._joints.publish(j)
        m = self._imu_msg
        m.header.stamp = stamp
        w, x, y, z = fields.quaternion
        m.orientation.w, m.orientation.x, m.orientation.y, m.orientation.z = w, x, y, z
        m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = fields.gyroscope
        m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = fields.accelerometer
        self._imu.publish(m)
