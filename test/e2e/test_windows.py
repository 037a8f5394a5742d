"""The last windows of leaving HIGH_LEVEL and of an e-stop from LOW_LEVEL, judged on the robot's record.

Both windows are a few ms on loopback and long on a robot; the sim's delay faults make them long here:

- HIGH_LEVEL -> LOW_LEVEL while walking: the StopMove must be settled before ReleaseMode reaches the robot
  (SetVelocity answered 0.4 s late: a ReleaseMode sent at once would overtake it).
- E-stop from LOW_LEVEL: SelectMode("ai") puts the released robot in zero torque; from then on no damping
  frame holds it, only a Damp does. The time between the two (neither held) is measured and bounded
  (CheckMode answered 0.3 s late: a Damp sent after the confirming CheckMode would come that much later).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

import pytest

from g1_mode_manager.protocol import api_ids
from support.mode_manager import wait_until
from support.sim_record import requests, states, velocity_of
from support.timing import DAMPING_UNTIL_SELECT_S, NEITHER_HELD_S, ROUND_TRIP_S, check_latency

pytestmark = [pytest.mark.e2e, pytest.mark.sim]



def _in_thread(call: Callable[[], Any]) -> Future:
    """Run ``call`` in a daemon thread; its result (or exception) lands in the returned future."""
    future: Future = Future()

    def run() -> None:
        try:
            future.set_result(call())
        except BaseException as exc:
            future.set_exception(exc)

    threading.Thread(target=run, daemon=True).start()
    return future


def test_the_stop_move_is_settled_before_release_mode_reaches_the_robot(shared_stack_factory) -> None:
    stack = shared_stack_factory(faults={"delay_s": {str(api_ids.LOCO_SET_VELOCITY): 0.4}}, bridge_args=("--gantry",))
    assert stack.set_mode("high_level").success
    assert stack.loco("start").success
    assert wait_until(lambda: stack.sim.get()["sport"]["fsm_id"] == 500, 5.0)
    t_walk = time.monotonic()
    stack.drive(0.3, 1.5)
    moves = [e for e in requests(stack.record.events(t_walk), api_ids.LOCO_SET_VELOCITY, kind="done")
             if velocity_of(e) != [0.0, 0.0, 0.0] and e["code"] == 0]
    assert moves, "no Move was acknowledged: the scenario exercised nothing"

    t0 = time.monotonic()
    r = stack.set_mode("low_level")
    assert r.success, r.message
    time.sleep(0.6)  # a StopMove sent alongside ReleaseMode is answered by now too (0.4 s late)
    events = stack.record.events(t0)
    stop_done = [e["t"] for e in requests(events, api_ids.LOCO_SET_VELOCITY, kind="done")
                 if velocity_of(e) == [0.0, 0.0, 0.0]]
    release = [e["t"] for e in requests(events, api_ids.MS_RELEASE_MODE)]
    assert release, "no ReleaseMode on the record"
    assert stop_done, "no StopMove answered on the record"
    stop_code = next(e["code"] for e in requests(events, api_ids.LOCO_SET_VELOCITY, kind="done")
                     if velocity_of(e) == [0.0, 0.0, 0.0])
    assert stop_done[0] < release[0], (f"ReleaseMode reached the robot {stop_done[0] - release[0]:.3f} s before "
                                       "the StopMove was answered")
    assert stop_code == 0, f"the StopMove was answered {stop_code}, not acknowledged"
    print(f"StopMove answered {release[0] - stop_done[0]:.3f} s before ReleaseMode reached the robot; "
          f"set_mode took {time.monotonic() - t0:.2f} s")


def test_an_estop_from_low_level_damps_the_moment_the_service_answers(shared_stack_factory) -> None:
    stack = shared_stack_factory(faults={"delay_s": {str(api_ids.MS_CHECK_MODE): 0.3}}, bridge_args=("--gantry",))
    r = stack.set_mode("low_level")
    assert r.success, r.message
    time.sleep(0.3)  # LOW_LEVEL, the node's damping frames flowing

    t0 = time.monotonic()
    reply = stack.estop()
    assert reply.success, reply.message
    time.sleep(0.3)
    events = stack.record.events(t0)
    selected = [e["t"] for e in requests(events, api_ids.MS_SELECT_MODE, kind="done")]
    assert selected, "no SelectMode on the record: the robot was not released"
    t_selected = selected[0]
    damped_at = [s["t"] for s in states(events) if s["t"] >= t_selected and s["fsm"] == 1 and s["svc"]]
    assert damped_at, "the robot never showed Damp after SelectMode"
    frames = [e["t"] for e in events if e["k"] == "frame" and e["topic"] == "lowcmd" and e["ok"]]
    held_until = max((t for t in frames if t <= t_selected), default=None)
    assert held_until is not None, "no damping frame took effect between the e-stop and SelectMode"
    neither = damped_at[0] - t_selected
    print(f"e-stop from LOW_LEVEL: last damping frame {1000 * (t_selected - held_until):.1f} ms before SelectMode "
          f"answered; Damp shown {1000 * neither:.1f} ms after it (neither holding the robot)")
    check_latency("e-stop from LOW_LEVEL: damping frames stopped before SelectMode answered", held_until, t_selected,
                  DAMPING_UNTIL_SELECT_S)
    check_latency("e-stop from LOW_LEVEL: held by nothing after SelectMode", t_selected, damped_at[0], NEITHER_HELD_S)


#: The e-stop's own budget in this test (estop_timeout_s) and its call timeout (estop_call_timeout_s).
ESTOP_TOTAL_S, ESTOP_CALL_S = 2.0, 0.5
#: The transitions' SelectMode timeout in that test: longer than the e-stop's budget with the slack below, so an
#: e-stop that waited for the transition's SelectMode would answer late; shorter than the default.
SELECT_S = 6.0


def test_an_estop_answers_within_its_budget_while_a_select_mode_never_returns(shared_stack_factory) -> None:
    """A SelectMode that never returns (held 30 s; the transition waits select_timeout_s 6 s for it, the e-stop's
    own SelectMode 5 s): the e-stop answers by estop_timeout_s + one call timeout, and says it is incomplete,
    never damped. The pre-empted mode change is answered too, once its SelectMode gave up."""
    stack = shared_stack_factory(faults={"delay_s": {str(api_ids.MS_SELECT_MODE): 30.0}}, bridge_args=("--gantry",),
                                 node_params=(f"estop_timeout_s:={ESTOP_TOTAL_S}", f"estop_call_timeout_s:={ESTOP_CALL_S}",
                                              f"select_timeout_s:={SELECT_S}"))
    assert stack.set_mode("low_level").success
    t_call = time.monotonic()
    pending = _in_thread(lambda: stack.set_mode("high_level"))
    assert wait_until(lambda: requests(stack.record.events(t_call), api_ids.MS_SELECT_MODE), 5.0)
    t0 = time.monotonic()
    reply = stack.estop()
    answered = time.monotonic() - t0
    print(f"e-stop with a SelectMode that never returns: answered after {answered:.2f} s "
          f"(budget {ESTOP_TOTAL_S} s + one call {ESTOP_CALL_S} s): {reply.message}")
    assert answered <= ESTOP_TOTAL_S + ESTOP_CALL_S + ROUND_TRIP_S, f"answered after {answered:.2f} s"
    assert not reply.success and "e-stop incomplete" in reply.message, reply.message
    # never claims more than is true: the robot was not damping when it answered
    assert not any(s["fsm"] == 1 and s["svc"] for s in states(stack.record.events(t0))), "damped after all?"
    # the pre-empted mode change is answered too (a failure, in EMERGENCY), not left to its caller's timeout
    answer = pending.result(timeout=SELECT_S + 5.0)
    print(f"the pre-empted set_mode answered {time.monotonic() - t_call:.2f} s after it was sent: {answer.message}")
    assert not answer.success and "preempted by e-stop" in answer.message, answer.message

