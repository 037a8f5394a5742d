"""The ROS 2 message definitions the incident files embed (ros2msg, as rosbag2's MCAP storage writes them), so a
reader decodes every message without this package or ROS installed.

Each is its interface file with comments and blank lines left out, its dependencies after a line of '=' and a
``MSG:`` line; test/flight_recorder/test_incident_writer.py checks them against the installed interface files.
"""

from __future__ import annotations

from typing import Final

_SEPARATOR: Final = "=" * 80

STRING: Final = ("std_msgs/msg/String", "string data\n")
FLOAT64: Final = ("std_msgs/msg/Float64", "float64 data\n")
TWIST: Final = ("geometry_msgs/msg/Twist", f"""Vector3 linear
Vector3 angular
{_SEPARATOR}
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
""")
JOINT_COMMAND: Final = ("g1_mode_manager_msgs/msg/JointCommand", f"""builtin_interfaces/Time stamp
string[] name
float64[] q
float64[] dq
float64[] tau
float64[] kp
float64[] kd
{_SEPARATOR}
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
""")

ALL: Final = (STRING, FLOAT64, TWIST, JOINT_COMMAND)
