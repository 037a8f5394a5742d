"""What the tests know of holosoma's shipped G1 policies, to tell their frames on the sim's record."""

from __future__ import annotations

#: The largest kp of holosoma's G1 locomotion policies (their ONNX metadata): what tells the policy's frames on the
#: record from the hand-over frame's (user_ctrl_hold_kp), a user's stream and damping (kp 0).
POLICY_KP_MAX = 99.098427777


def policy_frame(event: dict) -> bool:
    """A joint frame of the policy's stiffness."""
    return event["k"] == "frame" and abs(event["kp_max"] - POLICY_KP_MAX) < 1e-3
