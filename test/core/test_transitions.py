"""The transition table as data: exactly the legal pairs of the design, a reason for every other pair."""

from __future__ import annotations

import itertools

import pytest

from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.transitions import TABLE, TRANSITIONS, Step, Transition, Trigger, lookup

UN, ID, HI, LO, EM, FA = Mode.UNINITIALIZED, Mode.IDLE, Mode.HIGH_LEVEL, Mode.LOW_LEVEL, Mode.EMERGENCY, Mode.FAULT

LEGAL_REQUESTS = ({(UN, ID), (UN, HI), (UN, LO), (ID, HI), (ID, LO), (HI, ID), (HI, LO), (LO, ID), (LO, HI)}
                  | {(m, EM) for m in Mode})
LEGAL_BODY_CHECK = {(ID, FA), (HI, FA), (LO, FA)}
LEGAL_CLEAR = {(FA, ID)}
LEGAL = LEGAL_REQUESTS | LEGAL_BODY_CHECK | LEGAL_CLEAR
BY_TRIGGER = {Trigger.REQUEST: LEGAL_REQUESTS, Trigger.BODY_CHECK: LEGAL_BODY_CHECK, Trigger.CLEAR_FAULT: LEGAL_CLEAR,
              Trigger.SILENCE: set()}  # a silence hand-back exists on the user_ctrl path only

ALL_PAIRS = list(itertools.product(Mode, Mode))


def test_table_holds_exactly_the_legal_pairs_once() -> None:
    pairs = [(t.source, t.target) for t in TRANSITIONS]
    assert len(pairs) == len(set(pairs)), "a pair is listed twice"
    assert set(pairs) == LEGAL
    assert set(TABLE) == LEGAL


@pytest.mark.parametrize(("source", "target"), ALL_PAIRS, ids=lambda m: m.name)
@pytest.mark.parametrize("trigger", list(Trigger), ids=lambda t: t.value)
def test_every_pair_is_legal_or_refused_with_a_reason(source: Mode, target: Mode, trigger: Trigger) -> None:
    rule = lookup(source, target, trigger)
    if (source, target) in BY_TRIGGER[trigger]:
        assert isinstance(rule, Transition)
        assert (rule.source, rule.target) == (source, target)
        assert rule.description
    else:
        assert isinstance(rule, str)
        assert rule.strip()


@pytest.mark.parametrize("target", [UN, ID, HI, LO], ids=lambda m: m.name)
def test_nothing_leaves_emergency(target: Mode) -> None:
    assert "nothing leaves EMERGENCY" in str(lookup(EM, target))


@pytest.mark.parametrize("source", [ID, HI, LO], ids=lambda m: m.name)
def test_nothing_goes_back_to_uninitialized(source: Mode) -> None:
    assert "nothing goes back to UNINITIALIZED" in str(lookup(source, UN))


@pytest.mark.parametrize("mode", [UN, ID, HI, LO], ids=lambda m: m.name)
def test_same_mode_is_refused_as_already_there(mode: Mode) -> None:
    assert lookup(mode, mode) == f"already in {mode.name}; nothing to do"


def test_repeated_estop_is_legal() -> None:
    rule = lookup(EM, EM)
    assert isinstance(rule, Transition)
    assert rule.steps == (Step.ESTOP,)


def test_steps_connect_first_only_from_uninitialized() -> None:
    for t in TRANSITIONS:
        if t.target is FA:
            assert t.steps == (Step.PROTECTIVE_STOP,)
        elif t.target is EM:
            assert t.steps == (Step.ESTOP,)
        elif t.source is UN:
            assert t.steps[0] is Step.CONNECT
        else:
            assert Step.CONNECT not in t.steps


def test_steps_match_the_target_mode() -> None:
    for t in TRANSITIONS:
        if t.target is HI:
            assert t.steps[-1] is Step.ENSURE_SERVICE_ACTIVE
        elif t.target is LO:
            assert t.steps[-1] is Step.RELEASE_SERVICE
        elif t.target is ID:
            assert Step.ENSURE_SERVICE_ACTIVE not in t.steps
            assert Step.RELEASE_SERVICE not in t.steps


def test_fault_is_entered_only_by_a_body_check_and_left_only_by_clear_or_estop() -> None:
    for source in (ID, HI, LO):
        assert "not requested" in str(lookup(source, FA))
        rule = lookup(source, FA, Trigger.BODY_CHECK)
        assert isinstance(rule, Transition) and rule.steps == (Step.PROTECTIVE_STOP,)
    for target in (ID, HI, LO):
        assert "clear_fault" in str(lookup(FA, target))
    assert isinstance(lookup(FA, ID, Trigger.CLEAR_FAULT), Transition)
    assert lookup(FA, ID, Trigger.CLEAR_FAULT).steps == ()  # the robot stays damped  # type: ignore[union-attr]
    assert isinstance(lookup(FA, EM), Transition)
    assert "nothing leaves EMERGENCY" in str(lookup(EM, FA, Trigger.BODY_CHECK))
    assert "not connected" in str(lookup(UN, FA, Trigger.BODY_CHECK))


@pytest.mark.parametrize(("source", "target"), ALL_PAIRS, ids=lambda m: m.name)
@pytest.mark.parametrize("trigger", list(Trigger), ids=lambda t: t.value)
def test_the_user_ctrl_path_has_the_same_pairs_plus_the_silence_hand_back(source: Mode, target: Mode,
                                                                           trigger: Trigger) -> None:
    rule = lookup(source, target, trigger, user_ctrl=True)
    legal = BY_TRIGGER[trigger] | ({(LO, ID)} if trigger is Trigger.SILENCE else set())
    if (source, target) in legal:
        assert isinstance(rule, Transition) and (rule.source, rule.target) == (source, target)
        if LO in (source, target) and target not in (EM, FA):  # no ReleaseMode, no SelectMode: never limp
            assert Step.RELEASE_SERVICE not in rule.steps and Step.ENSURE_SERVICE_ACTIVE not in rule.steps
            assert not rule.leaves_robot_limp
    else:
        assert isinstance(rule, str) and rule.strip()
