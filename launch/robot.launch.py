"""The mode manager for a real G1, on the network interface wired to the robot (192.168.123.x).

    ros2 launch g1_mode_manager robot.launch.py network_interface:=eth0 [params_file:=...] [namespace:=] [console:=false]

``network_interface`` is required: the default 'lo' of the node reaches no robot. A real G1 uses Unitree
SDK2 DDS domain 0. joint_states and ~/imu are on here (50 Hz) for robot_state_publisher and rviz.
A params file of your own must name the node ``/**/g1_mode_manager`` (or ``/**``) to apply in a namespace.

The operator console is off by default here: a web page that can drive a real humanoid is a capability the
person launching it should ask for (``console:=true``: loopback only; others on the robot's network need
``console_host:=0.0.0.0 console_token_file:=<file>``), not one a robot gets by surprise.
"""

from __future__ import annotations

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

PACKAGE = "g1_mode_manager"


def generate_launch_description() -> LaunchDescription:
    default_params = os.path.join(get_package_share_directory(PACKAGE), "config", "mode_manager.yaml")
    return LaunchDescription([
        DeclareLaunchArgument("network_interface",
                              description="network interface wired to the robot (e.g. eth0, enp3s0); required"),
        DeclareLaunchArgument("params_file", default_value=default_params, description="mode manager parameters"),
        DeclareLaunchArgument("namespace", default_value="", description="ROS namespace of the node, e.g. /g1_a"),
        DeclareLaunchArgument("dds_domain", default_value="0", description="Unitree SDK2 DDS domain (a G1 uses 0)"),
        DeclareLaunchArgument("odom_rate_hz", default_value="20.0",
                              description="odom + odom->pelvis TF from the robot's rt/lf/odommodestate, Hz (0 = off)"),
        DeclareLaunchArgument("console", default_value="false",
                              description="start the operator console (web page): off on a real robot unless asked"),
        DeclareLaunchArgument("console_host", default_value="127.0.0.1",
                              description="the console's bind address; beyond loopback it needs console_token_file"),
        DeclareLaunchArgument("console_port", default_value="8080", description="the console's TCP port"),
        DeclareLaunchArgument("console_token_file", default_value="",
                              description="file whose first line is the token every console request must present"),
        DeclareLaunchArgument("joint_state_rate_hz", default_value="50.0",
                              description="joint_states and ~/imu rate from rt/lowstate, Hz (0 = off)"),
        # No `name=`: a node-name remap would also rename the node's e-stop and services side nodes.
        Node(package=PACKAGE, executable="mode_manager", namespace=LaunchConfiguration("namespace"), output="screen",
             parameters=[LaunchConfiguration("params_file"), {
                 "network_interface": LaunchConfiguration("network_interface"),
                 "dds_domain": ParameterValue(LaunchConfiguration("dds_domain"), value_type=int),
                 "joint_state_rate_hz": ParameterValue(LaunchConfiguration("joint_state_rate_hz"), value_type=float),
                 "odom_rate_hz": ParameterValue(LaunchConfiguration("odom_rate_hz"), value_type=float),
             }],
             # one DDS stack per process: never rmw_cyclonedds beside the SDK's Cyclone (node/one_dds_stack.py),
             # whatever the shell exports for the other nodes
             additional_env={"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}),
        # a process of its own: its crash never touches the mode manager, which never depends on it
        Node(package=PACKAGE, executable="console", namespace=LaunchConfiguration("namespace"), output="screen",
             condition=IfCondition(LaunchConfiguration("console")),
             parameters=[{"host": LaunchConfiguration("console_host"),
                          "port": ParameterValue(LaunchConfiguration("console_port"), value_type=int),
                          "token_file": LaunchConfiguration("console_token_file")}],
             additional_env={"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}),  # the product's RMW, as the node's
    ])
