"""Joint command validation: names, lengths, finiteness, gains and torques."""

import math

import pytest

from g1_mode_manager.core.joint_commands import (
    JointCommandError,
    damping_frame,
    validate_arm_targets,
    validate_lowcmd,
)
from g1_mode_manager.protocol.motors import DAMPING_KD, JOINT_INDEX


def test_valid_lowcmd_fills_the_frame_and_damps_the_rest() -> None:
    frame = validate_lowcmd(["left_knee_joint"], [0.6], [], [2.0], [60.0], [2.0])
    knee = frame[JOINT_INDEX["left_knee_joint"]]
    assert (knee.q, knee.dq, knee.tau, knee.kp, knee.kd) == (0.6, 0.0, 2.0, 60.0, 2.0)
    others = [c for i, c in enumerate(frame) if i != JOINT_INDEX["left_knee_joint"]]
    assert len(frame) == 29 and all(c.kp == 0.0 and c.kd == DAMPING_KD for c in others)


@pytest.mark.parametrize(
    ("names", "q", "kp", "kd", "tau", "match"),
    [
        (["knee"], [0.0], [1.0], [1.0], [], "unknown or not allowed"),
        (["left_knee_joint", "left_knee_joint"], [0, 0], [1, 1], [1, 1], [], "duplicate"),
        (["left_knee_joint"], [0.0, 1.0], [1.0], [1.0], [], "q has 2 entries"),
        (["left_knee_joint"], [math.nan], [1.0], [1.0], [], "non-finite"),
        (["left_knee_joint"], [0.0], [-1.0], [1.0], [], "gains"),
        (["left_knee_joint"], [0.0], [1.0], [1e6], [], "gains"),
        (["left_wrist_yaw_joint"], [0.0], [1.0], [1.0], [6.0], "effort limit"),
        ([], [], [], [], [], "no joint names"),
    ],
)
def test_bad_lowcmd_is_refused_with_a_reason(names, q, kp, kd, tau, match) -> None:
    with pytest.raises(JointCommandError, match=match):
        validate_lowcmd(names, q, [], tau, kp, kd)


@pytest.mark.parametrize("dq", [1e39, -1e300])
def test_a_velocity_target_the_robots_float32_cannot_hold_is_refused_not_sent_as_infinity(dq: float) -> None:
    import numpy as np

    from g1_mode_manager.core.joint_commands import validate_lowcmd_block

    with pytest.raises(JointCommandError, match="float32"):
        validate_lowcmd(["left_knee_joint"], [0.6], [dq], [], [60.0], [2.0])
    with pytest.raises(JointCommandError, match="float32"):
        validate_lowcmd_block(["left_knee_joint"], np.array([[0.6], [dq], [0.0], [60.0], [2.0]]))


def test_arm_targets_only_waist_and_arms() -> None:
    assert validate_arm_targets(["left_elbow_joint"], [0.3]) == {JOINT_INDEX["left_elbow_joint"]: 0.3}
    with pytest.raises(JointCommandError, match="not allowed"):
        validate_arm_targets(["left_knee_joint"], [0.3])
    with pytest.raises(JointCommandError, match="entries"):
        validate_arm_targets(["left_elbow_joint"], [])
    with pytest.raises(JointCommandError, match="non-finite"):
        validate_arm_targets(["left_elbow_joint"], [math.inf])


def test_damping_frame_is_soft() -> None:
    frame = damping_frame()
    assert len(frame) == 29 and all(c.kp == 0.0 and c.kd > 0.0 and c.tau == 0.0 for c in frame)
