"""Up again after a fall, judged on the sim's record: a damped robot on the floor is not stood up by
stand_up (refused by the node, nothing sent), lie_to_stand raises it and is answered once the robot stands
at 702 (asked again, "already standing", nothing sent); a fall after the get-up is a fall (FAULT); an e-stop
during the get-up damps it; and the whole story,
a walking robot pushed over -> FAULT -> clear_fault -> g1ctl recover (one command, from IDLE) -> start -> walks
again, with the vendor's get-up on the request topic: damp, then lie-to-stand."""

from __future__ import annotations

import subprocess
import threading
import time

import pytest
from g1_mode_manager_msgs.msg import Mode as ModeMsg

from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from support.mode_manager import wait_until
from support.processes import python_module
from support.sim_record import fsm_of, is_damp, requests, states

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

#: How far the robot must walk after getting up: the walk the vendor's flows are for, not a step.
WALKS_M = 1.0

#: Pushes a robot in lock stand over (docs/sim.md: 60 N x 0.2 s forward already does).
TIP_OVER = {"push": {"force": 150, "direction": [1, 0], "duration": 0.3}}
#: Pushes a walking robot over (docs/sim.md: the policy falls at 300 N x 0.2 s).
KNOCK_DOWN = {"push": {"force": 450, "direction": [1, 0], "duration": 0.3}}


def _watching(stack):
    """The test's ~/mode subscription, made before anything happens (a late one sees only the latest)."""
    assert wait_until(lambda: len(stack.modes()) > 0, 10.0), "no ~/mode received"
    return stack


def _lying_damped(stack) -> float:
    """HIGH_LEVEL, damped, and lying on the floor (as the sim reports it); returns when the damp was sent."""
    assert stack.set_mode("high_level").success
    sent = time.monotonic()
    assert stack.loco("damp").success
    assert wait_until(lambda: stack.sim.get()["body"]["posture"] == "on_back", 10.0), stack.sim.get()["body"]
    time.sleep(0.5)  # the node's body watch reads the attitude at its own rate
    return sent


def _set_fsm_requests(stack, since: float) -> list[int]:
    return [fsm_of(e) for e in requests(stack.record.events(since), api_ids.LOCO_SET_FSM_ID)]


def test_a_lying_robot_gets_up_only_through_lie_to_stand_and_falls_count_again_once_up(shared_stack_factory) -> None:
    stack = _watching(shared_stack_factory())
    since = _lying_damped(stack)

    for verb in ("stand_up", "squat_to_stand"):
        r = stack.loco(verb)
        assert not r.success and r.code == -1, r.message
        assert "the robot lies on the floor" in r.message and "damp, then lie_to_stand" in r.message, r.message
    assert _set_fsm_requests(stack, since) == [FsmId.DAMP], "a refused verb reached the robot"

    sent = time.monotonic()
    r = stack.loco("lie_to_stand")
    answered = time.monotonic()
    assert r.success and r.code == 0, r.message
    seen = [e for e in states(stack.record.events(sent)) if e["fsm"] == FsmId.LIE_TO_STAND]
    rising = [e["t"] for e in seen if e["fsm_mode"] == FsmMode.DYNAMIC]
    up = [e["t"] for e in seen if e["fsm_mode"] == FsmMode.STATIC]
    assert rising and up and min(rising) < min(up) <= answered, seen
    print(f"lie_to_stand: 702 shown after {min(rising) - sent:.2f} s, standing after {min(up) - sent:.2f} s, "
          f"answered after {answered - sent:.2f} s (outcome_s {r.outcome_s:.2f}); pelvis "
          f"{stack.sim.get()['body']['pelvis_z']:.2f} m")
    assert stack.sim.get()["body"]["pelvis_z"] > 0.7
    assert stack.modes()[-1].mode == ModeMsg.HIGH_LEVEL, "the get-up from the floor tripped a body check"

    again = stack.loco("lie_to_stand")  # standing now: its outcome holds already, nothing sent
    assert again.success and again.code == -1, again.message
    assert again.message.startswith("lie_to_stand: already standing"), again.message

    stack.set_faults(TIP_OVER)  # standing at 702: a fall is a fall
    assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.FAULT, 10.0), \
        [(m.mode, list(m.faults)) for m in stack.modes()[-3:]]
    assert any(f.startswith(("tilt", "spin")) for f in stack.modes()[-1].faults), list(stack.modes()[-1].faults)


def test_an_estop_during_the_get_up_damps_the_robot(shared_stack_factory) -> None:
    stack = _watching(shared_stack_factory())
    _lying_damped(stack)
    answers: list = []
    waiter = threading.Thread(target=lambda: answers.append(stack.loco("lie_to_stand")))
    sent = time.monotonic()
    waiter.start()
    assert wait_until(lambda: any(e["fsm"] == FsmId.LIE_TO_STAND for e in states(stack.record.events(sent))), 10.0)
    time.sleep(0.5)  # well inside the get-up: 702 raises the robot for ~5.6 s of sim time, and half a second in it
    # is past its start (the e-stop lands on a get-up under way, not on one still being accepted)
    pressed = time.monotonic()
    r = stack.estop()
    assert r.success, r.message
    waiter.join(15.0)
    assert answers and not answers[0].success and "preempted by e-stop" in answers[0].message, answers
    assert any(is_damp(e) for e in requests(stack.record.events(pressed))), "no Damp after the e-stop"
    last = states(stack.record.events(pressed))[-1]
    assert last["fsm"] == FsmId.DAMP, last


def test_a_walking_robot_pushed_over_is_walking_again_after_clear_fault_and_recover(shared_stack_factory) -> None:
    stack = _watching(shared_stack_factory())
    t0 = time.monotonic()
    steps: list[tuple[str, float, str]] = []

    def step(name: str) -> None:
        sport, body = stack.sim.get()["sport"], stack.sim.get()["body"]
        steps.append((name, time.monotonic() - t0, f"fsm {sport['fsm_id']} (fsm_mode {sport['fsm_mode']}), "
                                                  f"pelvis {body['pelvis_z']:.2f} m, {body['posture']}"))

    assert stack.set_mode("high_level").success
    assert stack.loco("start").success
    # pushed after a second of walking (the walk's ramp takes 0.3 s: the robot steps), while the teleop still drives
    walker = threading.Thread(target=stack.drive, args=(0.4, 2.0))
    walker.start()
    time.sleep(1.0)
    stack.set_faults(KNOCK_DOWN)
    walker.join()
    assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.FAULT and stack.modes()[-1].damp_confirmed, 10.0), \
        [(m.mode, list(m.faults)) for m in stack.modes()[-3:]]
    step("pushed over: FAULT, damped")
    assert wait_until(lambda: stack.sim.get()["body"]["posture"] != "upright", 10.0)
    stack.set_faults({})

    assert wait_until(lambda: stack.clear_fault().success, 15.0, period_s=0.5), "clear_fault never succeeded"
    step("clear_fault: IDLE")
    t_recover = time.monotonic()

    # one command from IDLE: HIGH_LEVEL, damp, the get-up the posture calls for, balance stand
    recover = subprocess.run(python_module("g1_mode_manager.cli.main", "recover"), capture_output=True, text=True,
                             timeout=90)
    assert recover.returncode == 0, recover.stdout + recover.stderr
    assert recover.stdout.strip().endswith("recover: the robot stands"), recover.stdout
    step("g1ctl recover")
    print(recover.stdout)
    assert _set_fsm_requests(stack, t_recover) == [FsmId.DAMP, FsmId.LIE_TO_STAND]
    assert [e["api"] for e in requests(stack.record.events(t_recover), api_ids.LOCO_SET_BALANCE_MODE)] == [
        api_ids.LOCO_SET_BALANCE_MODE]

    assert stack.loco("start").success
    walked = stack.walk_forward(0.5, WALKS_M)
    step(f"start, walked {walked:.2f} m")
    for name, t, shown in steps:
        print(f"{t:6.2f} s  {name}: {shown}")
    fsms = [e["fsm"] for e in states(stack.record.events(t0))]
    print(f"fsm sequence on the record: {[f for i, f in enumerate(fsms) if i == 0 or f != fsms[i - 1]]}")
    assert walked >= WALKS_M, f"walked only {walked:.2f} m"
    assert stack.modes()[-1].mode == ModeMsg.HIGH_LEVEL
