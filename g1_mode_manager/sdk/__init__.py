"""The robot port over Unitree SDK2 DDS: RPC clients, arm_sdk/lowcmd writers, state readers (no ROS here)."""

from g1_mode_manager.sdk.robot import UnitreeRobot

__all__ = ["UnitreeRobot"]
