"""QoS of the mode manager's topics that a subscriber must match.

A ROS-level contract between the node and its clients (g1ctl, the demo, tests): it lives beside both,
so a client imports nothing of the node.
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

#: ~/mode: a late `ros2 topic echo` still sees the current mode.
MODE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
