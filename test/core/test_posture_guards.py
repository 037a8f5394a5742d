"""The posture verbs the robot's body allows, as the vendor's flows give them: a lying robot gets up only
through lie_to_stand, from damping; from the squat 706 left, squat_to_stand only after a damp; stand_to_squat
only from standing."""

from __future__ import annotations

import pytest

from g1_mode_manager.core.body.checks import holds_upright
from g1_mode_manager.core.posture import NO_READING, Posture, PostureReading
from g1_mode_manager.core.posture_guards import DAMP_THEN_SQUAT_TO_STAND, POSTURE_VERBS, posture_refusal
from g1_mode_manager.protocol.fsm import FsmId, FsmMode

LYING = PostureReading(Posture.LYING_BACK, 1.8)
STANDING = PostureReading(Posture.STANDING, 0.05)
SQUATTING = PostureReading(Posture.SQUATTING, 0.04)
ON_THE_WAY = PostureReading(Posture.UNKNOWN, 0.3)


def test_lie_to_stand_only_damped_and_lying() -> None:
    assert posture_refusal("lie_to_stand", FsmId.DAMP, LYING) is None
    assert posture_refusal("lie_to_stand", FsmId.DAMP, PostureReading(Posture.LYING_FRONT, 1.8)) is None
    assert posture_refusal("lie_to_stand", FsmId.STAND_UP, LYING) == (
        "lie_to_stand gets a damped robot up from the floor, and the robot shows fsm 4: damp first")
    assert posture_refusal("lie_to_stand", FsmId.ZERO_TORQUE, LYING).endswith("damp first")
    assert "the robot is not lying (standing, tilt 0.05 rad)" in posture_refusal("lie_to_stand", FsmId.DAMP, STANDING)
    assert "not lying (squatting" in posture_refusal("lie_to_stand", FsmId.DAMP, SQUATTING)  # the power-on squat: 706
    assert "not lying (unknown, tilt 0.30 rad)" in posture_refusal("lie_to_stand", FsmId.DAMP, ON_THE_WAY)


@pytest.mark.parametrize("verb", ["stand_up", "squat_to_stand"])
def test_stand_ups_on_the_feet_are_refused_while_the_robot_lies(verb: str) -> None:
    assert posture_refusal(verb, FsmId.DAMP, LYING) == (
        "the robot lies on the floor (lying_back, tilt 1.80 rad): damp, then lie_to_stand")
    assert posture_refusal(verb, FsmId.DAMP, ON_THE_WAY) is None  # the robot decides (it stays down if it lies)


def test_squat_to_stand_from_the_squat_706_left_needs_a_damp_first() -> None:
    """The vendor's note: back in the squat from main motion control, getting up again is damp, then 706; from a
    damped squat (the power-on flow, or after that damp) it is allowed."""
    refusal = posture_refusal("squat_to_stand", FsmId.SQUAT_TO_STAND, SQUATTING)
    assert refusal == ("the robot squats where 706 left it (fsm 706, squatting, tilt 0.04 rad); the vendor's way up "
                       "from there: damp first, then squat_to_stand")
    assert refusal.endswith(DAMP_THEN_SQUAT_TO_STAND)
    assert posture_refusal("squat_to_stand", FsmId.DAMP, SQUATTING) is None
    assert posture_refusal("squat_to_stand", FsmId.SQUAT, SQUATTING) is None  # squat (2): 706 stands it up
    assert posture_refusal("squat_to_stand", FsmId.SQUAT_TO_STAND, ON_THE_WAY) is None  # 706 still moving: not squatting


@pytest.mark.parametrize("reading", [SQUATTING, PostureReading(Posture.SITTING, 0.06), ON_THE_WAY,
                                     PostureReading(Posture.HANGING, 0.17), LYING])
def test_stand_to_squat_only_from_standing(reading: PostureReading) -> None:
    refusal = posture_refusal("stand_to_squat", FsmId.DAMP, reading)
    assert refusal is not None and refusal.startswith("stand_to_squat squats a standing robot down"), refusal
    assert posture_refusal("stand_to_squat", FsmId.STAND_UP, STANDING) is None


@pytest.mark.parametrize("verb", sorted(POSTURE_VERBS))
def test_a_posture_verb_is_refused_while_no_state_sample_says_where_the_body_is(verb: str) -> None:
    refusal = posture_refusal(verb, FsmId.DAMP, NO_READING)
    assert refusal is not None and "posture is unknown (no state sample" in refusal, refusal


@pytest.mark.parametrize("verb", ["damp", "zero_torque", "start", "wave_hand", "high_stand"])
def test_other_verbs_are_not_judged_on_the_posture(verb: str) -> None:
    for reading in (LYING, NO_READING, SQUATTING):
        assert posture_refusal(verb, FsmId.SQUAT_TO_STAND, reading) is None


def test_702_holds_the_robot_upright_only_once_its_get_up_finished() -> None:
    assert not holds_upright(FsmId.LIE_TO_STAND, FsmMode.DYNAMIC)  # rising from the floor, tilted by design
    assert holds_upright(FsmId.LIE_TO_STAND, FsmMode.STATIC)  # standing at 702: a tilt is a fall
    assert holds_upright(FsmId.SQUAT_TO_STAND, FsmMode.DYNAMIC) and holds_upright(FsmId.STAND_UP, FsmMode.STATIC)
    for fsm in (FsmId.DAMP, FsmId.ZERO_TORQUE, FsmId.SQUAT, FsmId.SIT):
        assert not holds_upright(fsm, FsmMode.STATIC)
