"""One DDS stack per process: the node refuses an RMW that would load a second Cyclone DDS beside the SDK's.

The Unitree SDK talks to the robot through the cyclonedds Python package and its own libddsc. rmw_cyclonedds
loads another libddsc (another version, other globals) into the same process, and a process holding both
has been reported to corrupt its heap (grove-g1 runs rmw_fastrtps for that reason). The node therefore
runs on any other RMW; rmw_fastrtps (ROS 2's default) talks to nodes on rmw_cyclonedds over the wire as usual.
"""

from __future__ import annotations

from collections.abc import Mapping

ADVICE = ("Run the mode manager in its own process with RMW_IMPLEMENTATION=rmw_fastrtps_cpp (ROS 2's default; "
          "it talks to nodes on rmw_cyclonedds_cpp over the network as usual), e.g. "
          "`RMW_IMPLEMENTATION=rmw_fastrtps_cpp ros2 run g1_mode_manager mode_manager`, or launch it with "
          "robot.launch.py, which sets it for the node alone.")


def second_dds_stack(rmw: str | None) -> str | None:
    """Why ``rmw`` cannot share this process with the Unitree SDK, or None if it can."""
    if rmw and "cyclonedds" in rmw:
        return (f"refusing to start: RMW {rmw} would load a second Cyclone DDS (libddsc) into this process "
                "beside the Unitree SDK's, and two DDS stacks in one process have been reported to corrupt "
                f"its heap. {ADVICE}")
    return None


def refusal_from_environment(environ: Mapping[str, str]) -> str | None:
    """Checked before rclpy loads any RMW: RMW_IMPLEMENTATION as set (unset: the ROS default, Fast DDS)."""
    return second_dds_stack(environ.get("RMW_IMPLEMENTATION"))
