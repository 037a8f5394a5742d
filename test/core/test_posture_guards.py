"""The posture verbs the robot's body allows: a lying robot gets up only through lie_to_stand, from damping."""

from __future__ import annotations

import pytest

from g1_mode_manager.core.body.checks import holds_upright
from g1_mode_manager.core.posture_guards import LYING_TILT_RAD, posture_refusal
from g1_mode_manager.protocol.fsm import FsmId, FsmMode

LYING, STANDING = 1.8, 0.05


def test_lie_to_stand_only_damped_and_lying() -> None:
    assert posture_refusal("lie_to_stand", FsmId.DAMP, LYING) is None
    assert posture_refusal("lie_to_stand", FsmId.STAND_UP, LYING) == (
        "lie_to_stand gets a damped robot up from the floor, and the robot shows fsm 4: damp first")
    assert posture_refusal("lie_to_stand", FsmId.ZERO_TORQUE, LYING).endswith("damp first")
    assert "not lying (tilt 0.05 rad" in posture_refusal("lie_to_stand", FsmId.DAMP, STANDING)
    assert "attitude is unknown" in posture_refusal("lie_to_stand", FsmId.DAMP, None)
    assert posture_refusal("lie_to_stand", FsmId.DAMP, LYING_TILT_RAD) is not None  # at the limit: not lying


@pytest.mark.parametrize("verb", ["stand_up", "squat_to_stand"])
def test_stand_ups_on_the_feet_are_refused_while_the_robot_lies(verb: str) -> None:
    assert posture_refusal(verb, FsmId.DAMP, LYING) == (
        "the robot lies on the floor (tilt 1.80 rad): damp, then lie_to_stand")
    assert posture_refusal(verb, FsmId.DAMP, STANDING) is None
    assert posture_refusal(verb, FsmId.DAMP, None) is None  # unknown: the robot decides (it stays down)


@pytest.mark.parametrize("verb", ["damp", "zero_torque", "start", "stand_to_squat", "sit", "wave_hand"])
def test_other_verbs_are_not_judged_on_the_posture(verb: str) -> None:
    assert posture_refusal(verb, FsmId.DAMP, LYING) is None


def test_702_holds_the_robot_upright_only_once_its_get_up_finished() -> None:
    assert not holds_upright(FsmId.LIE_TO_STAND, FsmMode.DYNAMIC)  # rising from the floor, tilted by design
    assert holds_upright(FsmId.LIE_TO_STAND, FsmMode.STATIC)  # standing at 702: a tilt is a fall
    assert holds_upright(FsmId.SQUAT_TO_STAND, FsmMode.DYNAMIC) and holds_upright(FsmId.STAND_UP, FsmMode.STATIC)
    for fsm in (FsmId.DAMP, FsmId.ZERO_TORQUE, FsmId.SQUAT, FsmId.SIT):
        assert not holds_upright(fsm, FsmMode.STATIC)
