"""``python -m soak`` (with test/ on the path; ``make soak`` does it): see soak.run."""

from __future__ import annotations

import os
import sys

from support.domains import allocate_run_domains

# Like test/conftest.py, before anything imports rclpy or cyclonedds: domains of its own (held by file locks
# until the process exits), loopback only, the node's RMW.
_ROS_DOMAIN, _SDK_DOMAIN = allocate_run_domains()
os.environ["ROS_DOMAIN_ID"] = str(_ROS_DOMAIN)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_STATIC_PEERS", None)
os.environ["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
os.environ["G1_TEST_SDK_DOMAIN"] = str(_SDK_DOMAIN)
os.environ["PYTHONFAULTHANDLER"] = "1"  # a node that crashes prints every thread's Python stack

from soak.run import main  # noqa: E402

sys.exit(main(sdk_domain=_SDK_DOMAIN))
