"""Isolation of a run (the test suite's conftest, ``make soak``, ``make exits``) from every other on this machine.

Call ``isolate()`` before anything imports rclpy or cyclonedds.
"""

from __future__ import annotations

import os
import tempfile

from harness.processes import restore_sigint
from support.domains import allocate_run_domains


def isolate() -> tuple[int, int]:
    """Domains of its own (held by file locks until the process exits), loopback only, the node's RMW, a folder of its
    own for incident files, and children that stop on SIGINT however the run was started; returns (ROS_DOMAIN_ID,
    SDK domain)."""
    restore_sigint()
    ros_domain, sdk_domain = allocate_run_domains()
    os.environ["ROS_DOMAIN_ID"] = str(ros_domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("ROS_STATIC_PEERS", None)
    os.environ["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
    os.environ["G1_TEST_SDK_DOMAIN"] = str(sdk_domain)
    # the flight recorder's default folder: a run's nodes write their incidents beside its lock files, not into the
    # user's ~/.local/state (one folder per domain, so reused by later runs and bounded by the recorder's rotation)
    os.environ["XDG_STATE_HOME"] = os.path.join(tempfile.gettempdir(), f"g1_mode_manager_test_state_{ros_domain}")
    return ros_domain, sdk_domain
