"""Isolation of a run (the test suite's conftest, ``make soak``, ``make exits``) from every other on this machine.

Call ``isolate()`` before anything imports rclpy or cyclonedds.
"""

from __future__ import annotations

import os

from harness.processes import restore_sigint
from support.domains import allocate_run_domains


def isolate() -> tuple[int, int]:
    """Domains of its own (held by file locks until the process exits), loopback only, the node's RMW, and children
    that stop on SIGINT however the run was started; returns (ROS_DOMAIN_ID, SDK domain)."""
    restore_sigint()
    ros_domain, sdk_domain = allocate_run_domains()
    os.environ["ROS_DOMAIN_ID"] = str(ros_domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("ROS_STATIC_PEERS", None)
    os.environ["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
    os.environ["G1_TEST_SDK_DOMAIN"] = str(sdk_domain)
    return ros_domain, sdk_domain
