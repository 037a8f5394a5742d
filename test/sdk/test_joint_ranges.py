"""The joint ranges the frame checks use are the robot model's: read again from the sim's g1.xml."""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from g1_mode_manager.core.joint_commands import RANGE_MARGIN_RAD, JointCommandError, validate_lowcmd
from g1_mode_manager.protocol.motors import JOINT_NAMES, JOINT_RANGE_RAD
from g1_sim.assets import assets_dir


def test_joint_ranges_are_the_models():
    tree = ET.parse(assets_dir() / "unitree_g1" / "g1.xml")
    ranges = {j.get("name"): tuple(map(float, j.get("range").split())) for j in tree.iter("joint") if j.get("range")}
    assert tuple(ranges[name] for name in JOINT_NAMES) == JOINT_RANGE_RAD


@pytest.mark.parametrize("joint", ["left_wrist_yaw_joint", "left_knee_joint", "right_hip_roll_joint"])
def test_a_target_past_a_joints_range_is_refused_naming_the_joint(joint):
    i = JOINT_NAMES.index(joint)
    low, high = JOINT_RANGE_RAD[i]
    validate_lowcmd([joint], [high + RANGE_MARGIN_RAD * 0.9], [], [], [40.0], [1.0])  # within the margin: passes
    for q in (high + RANGE_MARGIN_RAD * 1.1, low - RANGE_MARGIN_RAD * 1.1, 100.0):
        with pytest.raises(JointCommandError, match=f"{joint} is outside its range"):
            validate_lowcmd([joint], [q], [], [], [40.0], [1.0])


def test_joint_speed_limits_are_those_of_unitrees_urdf_the_dance_models_carry():
    import json

    import onnxruntime as ort

    from g1_mode_manager.node.settings import POLICY_MODELS
    from g1_mode_manager.protocol.motors import VELOCITY_LIMIT_RAD_S

    model = Path(sys.prefix) / POLICY_MODELS / "ppo_g1_29dof_dancing.onnx"
    meta = ort.InferenceSession(str(model),
                                providers=["CPUExecutionProvider"]).get_modelmeta().custom_metadata_map
    urdf = ET.fromstring(json.loads(meta["robot_urdf"]))
    limits = {j.get("name"): float(j.find("limit").get("velocity")) for j in urdf.iter("joint")
              if j.find("limit") is not None}
    assert tuple(limits[name] for name in JOINT_NAMES) == VELOCITY_LIMIT_RAD_S
