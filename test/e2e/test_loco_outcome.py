"""~/loco_command is answered on what the robot shows, judged on the robot's record.

A posture motion (stand up, sit) takes seconds on the robot while its SetFsmId answers 0 at once: the
service's success must come after the record shows the motion finished (fsm_mode 0 in the new fsm). The
firmware quirk (SetFsmId(500) answers 0 and does nothing) must answer ``success: false`` with the fsm
the robot stayed in. And a command waiting for its outcome must neither delay an e-stop nor outlive it.
"""

from __future__ import annotations

import subprocess
import threading
import time

import pytest

from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.fsm import FsmId
from support.mode_manager import wait_until
from support.processes import python_module
from support.sim_record import fsm_of, is_damp, requests, states
from support.timing import ESTOP_NOT_HELD_S

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

#: Short enough for the firmware quirk's wait, long enough for any outcome but a posture motion's.
OUTCOME_TIMEOUT_S = 1.5



def _standing(stack) -> bool:
    sport = stack.sim.get()["sport"]
    return (sport["fsm_id"], sport["fsm_mode"]) == (FsmId.STAND_UP, 0)


def _timed(call):
    sent = time.monotonic()
    response = call()
    return sent, response, time.monotonic()


def _settled_in(stack, fsm: int, since: float) -> float | None:
    """When the record first shows ``fsm`` with fsm_mode 0 after ``since`` (None: not yet)."""
    found = [e["t"] for e in states(stack.record.events(since)) if e["fsm"] == fsm and e["fsm_mode"] == 0]
    return min(found) if found else None


def _answered_after(stack, api_id: int, since: float) -> float | None:
    """When the robot answered its first ``api_id`` request after ``since`` (its ``done`` line)."""
    done = requests(stack.record.events(since), api_id, kind="done")
    return done[0]["t"] if done else None


@pytest.fixture(scope="module")
def stack(module_stack_factory):
    """One robot for the file: the tests run in order, and only the last one e-stops it."""
    return module_stack_factory(node_params=(f"loco_outcome_timeout_s:={OUTCOME_TIMEOUT_S}",))


def test_each_command_is_answered_after_the_robot_shows_its_outcome(stack) -> None:
    assert stack.set_mode("high_level").success
    assert wait_until(lambda: _standing(stack), 15.0)

    # an arm task (the arms are free in the lock stand the robot boots in): answered once rt/sportmodestate shows it playing
    sent, r, answered = _timed(lambda: stack.loco("wave_hand"))
    assert r.success and "task 0 at" in r.message, r.message
    played = _answered_after(stack, api_ids.LOCO_SET_ARM_TASK, sent)
    assert played is not None and played <= answered

    # g1ctl prints the same answer, with the time to the outcome; it runs while the wave plays out (seconds of
    # sim time), as a balance mode changes no fsm and so leaves the wave alone (gait 0, as the robot booted)
    cli = subprocess.run(python_module("g1_mode_manager.cli.main", "loco", "continuous_gait", "0"),
                         capture_output=True, text=True, timeout=60)
    assert cli.returncode == 0, cli.stdout + cli.stderr
    assert cli.stdout.startswith("success=True code=0 outcome after "), cli.stdout
    assert "continuous_gait (value 0): done, the robot shows balance mode 0 after" in cli.stdout, cli.stdout
    assert wait_until(lambda: stack.sim.get()["sport"]["task"][1] == 0.0, 15.0)  # the wave played out

    # posture motions: the answer comes only once the motion finished (seconds after SetFsmId's 0)
    for command, fsm in (("damp", FsmId.DAMP), ("stand_up", FsmId.STAND_UP), ("sit", FsmId.SIT),
                         ("stand_up", FsmId.STAND_UP)):
        sent, r, answered = _timed(lambda c=command: stack.loco(c))
        assert r.success and r.code == 0 and r.outcome_s >= 0.0, (command, r.message)
        accepted = _answered_after(stack, api_ids.LOCO_SET_FSM_ID, sent)
        settled = _settled_in(stack, fsm, sent)
        assert accepted is not None and settled is not None, (command, "no SetFsmId or no settled state on the record")
        assert settled <= answered, f"{command}: answered {settled - answered:.3f} s before the robot showed fsm {fsm}"
        if command in ("stand_up", "sit"):  # the proof that code 0 alone would have answered too early
            assert settled - accepted > 0.5, f"{command}: settled {settled - accepted:.2f} s after its code 0"
        print(f"{command}: code 0 after {accepted - sent:.3f} s, fsm {fsm} settled after {settled - sent:.3f} s, "
              f"answered after {answered - sent:.3f} s (outcome_s {r.outcome_s:.3f})")

    sent, r, answered = _timed(lambda: stack.loco("start"))
    settled = _settled_in(stack, FsmId.START, sent)
    assert r.success and settled is not None and settled <= answered, r.message

    # getters: the answer comes after the robot answered a getter showing the new value
    for command, value, getter in (("continuous_gait", 1, api_ids.LOCO_GET_BALANCE_MODE),
                                   ("balance_stand", 0, api_ids.LOCO_GET_BALANCE_MODE),
                                   ("low_stand", 0, api_ids.LOCO_GET_STAND_HEIGHT),
                                   ("high_stand", 0, api_ids.LOCO_GET_STAND_HEIGHT)):
        sent, r, answered = _timed(lambda c=command, v=value: stack.loco(c, v))
        assert r.success and r.outcome_s >= 0.0, (command, r.message)
        set_done = [e["t"] for e in requests(stack.record.events(sent), kind="done") if e["api"] != getter]
        read_back = [e["t"] for e in requests(stack.record.events(sent), getter, kind="done")]
        assert set_done and read_back and max(read_back) > min(set_done), f"{command}: never read back after it was set"
        assert max(read_back) <= answered



def _stand_still(stack) -> None:
    """Back to the lock stand (from walking: fsm 4 straight away), in HIGH_LEVEL, hung in the gantry: the
    test before may leave the robot stepping, and locking a stand mid-step can topple it (a FAULT)."""
    stack.set_gantry(True)
    r = stack.set_mode("high_level")
    assert r.success or r.message.startswith("already in HIGH_LEVEL"), r.message
    # hung from the gantry, a walking robot sways; while its sway reads as moving (fsm_mode 1) the node, and
    # the controller itself (7301), refuse the lock stand: ask again, as an operator would, once it is still
    deadline = time.monotonic() + 10.0
    while not (r := stack.loco("stand_up")).success and time.monotonic() < deadline:
        assert "dynamic" in r.message or r.code == 7301, r.message
        time.sleep(0.3)
    assert r.success, r.message
    assert wait_until(lambda: _standing(stack), 15.0)


def test_start_ignored_by_the_firmware_answers_false_with_the_fsm_the_robot_stayed_in(stack) -> None:
    _stand_still(stack)
    stack.set_faults({"ignore_fsm_ids": [int(FsmId.START)]})
    sent, r, answered = _timed(lambda: stack.loco("start"))
    assert not r.success and r.code == 0 and r.outcome_s == -1.0
    assert r.message == f"start: code 0, but the robot showed fsm 4 (fsm_mode 0) for {OUTCOME_TIMEOUT_S} s", r.message
    events = stack.record.events(sent)
    done = [e for e in requests(events, api_ids.LOCO_SET_FSM_ID, kind="done") if fsm_of(e) == FsmId.START]
    assert done and done[0]["code"] == 0, "the robot did not answer SetFsmId(500) with 0"
    assert not [e for e in states(events) if e["fsm"] == FsmId.START], "the robot did start"
    assert answered - sent >= OUTCOME_TIMEOUT_S
    stack.set_faults({})


def test_an_estop_preempts_a_command_waiting_for_its_outcome_and_is_not_delayed_by_it(stack) -> None:
    _stand_still(stack)
    stack.set_faults({"ignore_fsm_ids": [int(FsmId.START)]})
    answers: list = []
    waiter = threading.Thread(target=lambda: answers.append((stack.loco("start"), time.monotonic())))
    sent = time.monotonic()
    waiter.start()
    assert wait_until(lambda: _answered_after(stack, api_ids.LOCO_SET_FSM_ID, sent) is not None, 5.0)
    time.sleep(0.3)  # the command is now waiting for an fsm 500 that will never come
    assert not answers, (answers, [(m.name, list(m.faults)) for m in stack.modes()[-3:]])
    estop_called = time.monotonic()
    e = stack.estop()
    estop_answered = time.monotonic()
    waiter.join(5.0)
    assert answers, "the loco command was never answered"
    loco, loco_answered = answers[0]
    assert not loco.success and loco.code == 0 and "preempted by e-stop" in loco.message, loco.message
    assert loco_answered - estop_called < 1.0, "the loco command outlived the e-stop"
    assert e.success, e.message
    first_damp = min(x["t"] for x in requests(stack.record.events(estop_called)) if is_damp(x))
    print(f"e-stop's first Damp at the robot {1000 * (first_damp - estop_called):.1f} ms after the call; e-stop "
          f"answered after {estop_answered - estop_called:.3f} s; loco answered {loco_answered - estop_called:.3f} s "
          f"after the e-stop's call: {loco.message}")
    assert first_damp - estop_called < ESTOP_NOT_HELD_S
