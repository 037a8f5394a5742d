"""The simulated G1's built-in rules: sport (loco) service, motion switcher, arm_sdk and lowcmd gating."""

from g1_sim.firmware.robot import SimG1
from g1_sim.firmware.state import BasePose, LowStateSnapshot

__all__ = ["BasePose", "LowStateSnapshot", "SimG1"]
