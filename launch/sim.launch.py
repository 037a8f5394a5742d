"""The simulated G1 (MuJoCo, Unitree SDK2 DDS on loopback) and the mode manager that drives it.

    ros2 launch g1_mode_manager sim.launch.py [domain:=0] [namespace:=] [speed:=1.0] [viewer:=false] [console:=true]

``domain`` is the Unitree SDK2 (Cyclone DDS) domain of the robot side, not ROS_DOMAIN_ID. With a
``namespace`` (e.g. /g1_a) the node serves /g1_a/g1_mode_manager/set_mode, listens to /g1_a/cmd_vel;
the sim publishes /g1_a/joint_states and its ground truth /g1_a/g1_sim_bridge/odom; /estop stays global (the
fleet-wide button), and so does the sim's /clock. For two robots, launch twice with different ``domain`` and ``namespace``
(and a different ``console_port``). The operator console (a web page, http://127.0.0.1:8080/) is on by default here:
a sim is where a browser teleop is wanted first, and it binds to loopback only.
"""

from __future__ import annotations

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

PACKAGE = "g1_mode_manager"


def generate_launch_description() -> LaunchDescription:
    domain = LaunchConfiguration("domain")
    namespace = LaunchConfiguration("namespace")
    speed = LaunchConfiguration("speed")
    viewer = LaunchConfiguration("viewer")
    params_file = LaunchConfiguration("params_file")
    default_params = os.path.join(get_package_share_directory(PACKAGE), "config", "mode_manager.yaml")
    bridge_args = ["--domain", domain, "--interface", "lo", "--speed", speed]
    # No `name=` on these Nodes: a node-name remap would also rename the mode manager's side nodes
    # (its e-stop and services executors), which must keep names of their own.
    return LaunchDescription([
        DeclareLaunchArgument("domain", default_value="0", description="Unitree SDK2 DDS domain of the sim (0..230)"),
        DeclareLaunchArgument("namespace", default_value="", description="ROS namespace of both nodes, e.g. /g1_a"),
        DeclareLaunchArgument("speed", default_value="1.0", description="sim time per wall time (0 = as fast as possible)"),
        DeclareLaunchArgument("viewer", default_value="false", description="open the MuJoCo viewer (needs a display)"),
        DeclareLaunchArgument("params_file", default_value=default_params, description="mode manager parameters"),
        DeclareLaunchArgument("odom_rate_hz", default_value="20.0",
                              description="odom + odom->pelvis TF from the robot's rt/lf/odommodestate, Hz (0 = off)"),
        DeclareLaunchArgument("console", default_value="true", description="start the operator console (web page)"),
        DeclareLaunchArgument("console_host", default_value="127.0.0.1",
                              description="the console's bind address; beyond loopback it needs console_token_file"),
        DeclareLaunchArgument("console_port", default_value="8080", description="the console's TCP port"),
        DeclareLaunchArgument("console_token_file", default_value="",
                              description="file whose first line is the token every console request must present"),
        DeclareLaunchArgument("joint_state_rate_hz", default_value="0.0",
                              description="mode manager joint_states/~/imu rate, Hz (0 = off: the sim publishes "
                                          "<namespace>/joint_states itself, from MuJoCo)"),
        Node(package=PACKAGE, executable="sim_bridge", namespace=namespace, output="screen",
             arguments=bridge_args, condition=UnlessCondition(viewer)),
        Node(package=PACKAGE, executable="sim_bridge", namespace=namespace, output="screen",
             arguments=[*bridge_args, "--viewer"], condition=IfCondition(viewer)),
        Node(package=PACKAGE, executable="mode_manager", namespace=namespace, output="screen",
             parameters=[params_file, {
                 "network_interface": "lo",
                 "dds_domain": ParameterValue(domain, value_type=int),
                 "joint_state_rate_hz": ParameterValue(LaunchConfiguration("joint_state_rate_hz"), value_type=float),
                 "odom_rate_hz": ParameterValue(LaunchConfiguration("odom_rate_hz"), value_type=float),
             }],
             # one DDS stack per process: never rmw_cyclonedds beside the SDK's Cyclone (node/one_dds_stack.py),
             # whatever the shell exports for the other nodes
             additional_env={"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}),
        # a process of its own: its crash never touches the mode manager, which never depends on it
        Node(package=PACKAGE, executable="console", namespace=namespace, output="screen",
             condition=IfCondition(LaunchConfiguration("console")),
             parameters=[{"host": LaunchConfiguration("console_host"),
                          "port": ParameterValue(LaunchConfiguration("console_port"), value_type=int),
                          "token_file": LaunchConfiguration("console_token_file")}],
             additional_env={"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}),  # the product's RMW, as the node's
    ])
