"""The node in a subprocess and a ROS client to drive it (``harness.mode_manager``, shared with the benchmarks),
under the name the tests import."""

from harness.mode_manager import RosClient, start_mode_manager, wait_until

__all__ = ["RosClient", "start_mode_manager", "wait_until"]
