"""When a posture verb's outcome is reached, and when it holds already (nothing is then sent): the fsm and the
posture together for the verbs that name a controller state, the posture alone for 706 and 702, whose fsm is
only the way there (706 even reverses a robot already where it was asked to go)."""

from __future__ import annotations

import pytest

from g1_mode_manager.core.loco_verbs import LOCO_VERBS, FsmShown
from g1_mode_manager.core.posture import Posture
from g1_mode_manager.protocol.fsm import FsmId, FsmMode

P = Posture
STATIC, DYNAMIC = FsmMode.STATIC, FsmMode.DYNAMIC


def _shown(verb: str) -> FsmShown:
    expected = LOCO_VERBS[verb].expect(0)
    assert isinstance(expected, FsmShown)
    return expected


@pytest.mark.parametrize(("verb", "fsm", "posture"), [
    ("stand_up", FsmId.STAND_UP, P.STANDING), ("squat", FsmId.SQUAT, P.SQUATTING), ("sit", FsmId.SIT, P.SITTING),
    ("squat_to_stand", FsmId.SQUAT_TO_STAND, P.STANDING), ("stand_to_squat", FsmId.SQUAT_TO_STAND, P.SQUATTING),
    ("lie_to_stand", FsmId.LIE_TO_STAND, P.STANDING),
])
def test_a_posture_verb_is_reached_on_its_fsm_at_rest_and_its_posture(verb: str, fsm: int, posture: Posture) -> None:
    shown = _shown(verb)
    assert shown.posture is posture
    assert shown.reached(fsm, STATIC, posture)
    assert not shown.reached(fsm, DYNAMIC, posture)  # still moving
    assert not shown.reached(fsm, STATIC, P.UNKNOWN)  # the fsm alone: 706 static is either end of its motion
    assert not shown.reached(FsmId.DAMP, STATIC, posture)


def test_706_is_reached_by_the_posture_it_was_asked_for_not_by_the_fsm_it_shows() -> None:
    up, down = _shown("squat_to_stand"), _shown("stand_to_squat")
    assert up.reached(FsmId.SQUAT_TO_STAND, STATIC, P.STANDING) and not down.reached(FsmId.SQUAT_TO_STAND, STATIC,
                                                                                      P.STANDING)
    assert down.reached(FsmId.SQUAT_TO_STAND, STATIC, P.SQUATTING) and not up.reached(FsmId.SQUAT_TO_STAND, STATIC,
                                                                                       P.SQUATTING)


@pytest.mark.parametrize(("verb", "fsm", "posture", "already"), [
    ("squat_to_stand", FsmId.STAND_UP, P.STANDING, True),  # standing in lock stand: 706 would squat it
    ("squat_to_stand", FsmId.START, P.STANDING, True),
    ("squat_to_stand", FsmId.SQUAT_TO_STAND, P.SQUATTING, False),
    ("squat_to_stand", FsmId.DAMP, P.SQUATTING, False),
    ("stand_to_squat", FsmId.SQUAT_TO_STAND, P.SQUATTING, True),  # squatting where 706 left it
    ("stand_to_squat", FsmId.DAMP, P.SQUATTING, True),  # the damped squat: 706 would stand it up
    ("stand_to_squat", FsmId.STAND_UP, P.STANDING, False),
    ("lie_to_stand", FsmId.LIE_TO_STAND, P.STANDING, True),
    ("lie_to_stand", FsmId.STAND_UP, P.STANDING, True),
    ("lie_to_stand", FsmId.DAMP, P.LYING_BACK, False),
    ("stand_up", FsmId.STAND_UP, P.STANDING, True),
    ("stand_up", FsmId.START, P.STANDING, False),  # standing, but walking: stand_up locks the stand
    ("stand_up", FsmId.STAND_UP, P.UNKNOWN, False),
    ("squat", FsmId.SQUAT, P.SQUATTING, True),
    ("squat", FsmId.SQUAT_TO_STAND, P.SQUATTING, False),
    ("sit", FsmId.SIT, P.SITTING, True),
    ("sit", FsmId.SIT, P.SQUATTING, False),
])
def test_an_outcome_that_holds_already(verb: str, fsm: int, posture: Posture, already: bool) -> None:
    shown = _shown(verb)
    assert shown.already(fsm, STATIC, posture) is already
    assert not shown.already(fsm, DYNAMIC, posture)  # on its way: not there yet


@pytest.mark.parametrize("verb", ["damp", "zero_torque", "start"])
def test_verbs_without_a_posture_are_never_answered_before_they_are_sent(verb: str) -> None:
    shown = _shown(verb)
    assert shown.posture is None
    assert not shown.already(shown.fsm_id, STATIC, P.STANDING)
    assert shown.reached(shown.fsm_id, STATIC, P.UNKNOWN)  # the fsm is their whole outcome
