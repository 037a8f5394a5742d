"""Posture verbs answered on the posture the robot reaches, judged on the sim's record: 706 squats a standing robot
and stands a squatting one, so squat_to_stand on a standing robot and stand_to_squat on a squatting one are
answered "already" with nothing sent, stand_to_squat is answered once ~/mode's posture (read from the joints)
squats, and squat_to_stand from the squat 706 left is refused with the vendor's rule (damp first), nothing sent."""

from __future__ import annotations

import time

import pytest

from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from support.mode_manager import wait_until
from support.sim_record import fsm_of, requests, states
from support.timing import QUIET_WINDOW_S

pytestmark = [pytest.mark.e2e, pytest.mark.sim]


def _set_fsm_requests(stack, since: float) -> list[int]:
    return [fsm_of(e) for e in requests(stack.record.events(since), api_ids.LOCO_SET_FSM_ID)]


def _posture(stack) -> str:
    return stack.modes()[-1].posture if stack.modes() else "no ~/mode"


def test_stand_to_squat_then_squat_to_stand_is_refused_with_nothing_sent(shared_stack_factory) -> None:
    stack = shared_stack_factory()
    assert wait_until(lambda: len(stack.modes()) > 0, 10.0), "no ~/mode received"
    assert stack.set_mode("high_level").success
    assert wait_until(lambda: _posture(stack) == "standing", 10.0), _posture(stack)
    began = time.monotonic()

    r = stack.loco("squat_to_stand")  # standing already: a 706 would squat it down
    assert r.success and r.code == -1 and r.message.startswith("squat_to_stand: already standing"), r.message

    sent = time.monotonic()
    down = stack.loco("stand_to_squat")
    answered = time.monotonic()
    assert down.success and down.code == 0, down.message
    assert "fsm 706 (fsm_mode 0), squatting" in down.message, down.message
    settled = [e["t"] for e in states(stack.record.events(sent))
               if e["fsm"] == FsmId.SQUAT_TO_STAND and e["fsm_mode"] == FsmMode.STATIC]
    assert settled and min(settled) <= answered, "answered before the robot showed 706 at rest"
    assert _posture(stack) == "squatting"
    assert stack.sim.get()["body"]["pelvis_z"] < 0.65, stack.sim.get()["body"]

    refused_at = time.monotonic()
    up = stack.loco("squat_to_stand")
    assert not up.success and up.code == -1, up.message
    assert up.message.endswith("damp first, then squat_to_stand"), up.message
    again = stack.loco("stand_to_squat")  # squatting already: a 706 would stand it up
    assert again.success and again.code == -1 and again.message.startswith("stand_to_squat: already squatting"), \
        again.message
    time.sleep(QUIET_WINDOW_S)  # a request sent would be on the record by now
    assert _set_fsm_requests(stack, refused_at) == [], "a refused or already-held verb reached the robot"
    assert _set_fsm_requests(stack, began) == [FsmId.SQUAT_TO_STAND]
    sport = stack.sim.get()["sport"]
    assert (sport["fsm_id"], sport["fsm_mode"]) == (FsmId.SQUAT_TO_STAND, 0) and _posture(stack) == "squatting"
    print(f"stand_to_squat: answered after {answered - sent:.2f} s (outcome_s {down.outcome_s:.2f}); "
          f"squat_to_stand: {up.message}")


def test_squat_to_stand_after_a_damp_stands_the_robot_up(shared_stack_factory) -> None:
    """The vendor's way up from the squat 706 left: damp, then squat_to_stand, answered once ~/mode reads the robot
    standing. Needs a sim whose damped fold rests on its feet (a damped upright squat tips onto its back)."""
    stack = shared_stack_factory()
    assert wait_until(lambda: len(stack.modes()) > 0, 10.0), "no ~/mode received"
    assert stack.set_mode("high_level").success
    assert wait_until(lambda: _posture(stack) == "standing", 10.0), _posture(stack)
    assert stack.loco("stand_to_squat").success
    assert stack.loco("damp").success
    assert wait_until(lambda: _posture(stack) == "squatting", 5.0), _posture(stack)  # damped, and folded on its feet
    sent = time.monotonic()
    up = stack.loco("squat_to_stand")
    assert up.success and up.code == 0 and "fsm 706 (fsm_mode 0), standing" in up.message, up.message
    assert _set_fsm_requests(stack, sent) == [FsmId.SQUAT_TO_STAND]
    assert stack.sim.get()["body"]["pelvis_z"] > 0.7, stack.sim.get()["body"]
