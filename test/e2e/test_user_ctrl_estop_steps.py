"""An e-stop inside each step of the user-control switch, the real node against the real sim, judged on
the sim's record.

Each test holds the node inside one step for STEP_HELD_S (the sim's delay_s on the step's robot call, or a rest the
node never sees), waits for the record to show the step begun, and sends the e-stop. The robot must then show what
docs/user_control.md promises: the e-stop answered success; damped at the end (fsm 1, out of user control); the
interrupted set_mode answered "preempted by e-stop"; no user frame after the e-stop; where the robot may be under
user control, a damping frame on rt/user_lowcmd no later than SwitchToInternalCtrl(PASSIVE), then a Damp; nothing on
rt/lowcmd. test_user_ctrl.py holds the e-stop in user control and inside the switch's delay after 7110's answer.

Not covered: the exit's window between SwitchToInternalCtrl(WALKRUN)'s answer and the standing fsm shown. The sim's
7111 hands the joints back inside its handler, before it answers, so that window does not exist on the sim.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable

import pytest

from e2e.user_ctrl_session import (
    STEADY,
    USER_CTRL,
    USER_KP,
    HoldController,
    enter_walking,
    frames_on,
    fsm_states,
    held_in_user_ctrl,
)
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import USER_CTRL_FSM_ID, InternalCtrl
from support.mode_manager import wait_until
from support.sim_record import is_damp, of_kind, requests
from support.timing import RECORD_WAIT_S, ROUND_TRIP_S, STEP_HELD_S

pytestmark = pytest.mark.e2e

#: The node's own timeout of a robot call outlasts the sim's hold of it: the held call lands, it does not time out.
HELD_CALL = f"rpc_timeout_s:={STEP_HELD_S + ROUND_TRIP_S}"
#: The entry's rest wait held open: the least the node accepts (1 mrad/s), which a balancing robot does not hold on
#: three samples in a row, so the node waits out its rest timeout.
REST_HELD = ("user_ctrl_rest_speed_rad_s:=0.001", f"user_ctrl_rest_timeout_s:={STEP_HELD_S}")
MOTION_SWITCHER_CHANGES = (api.MS_SELECT_MODE, api.MS_RELEASE_MODE)


def _in_background(call: Callable[[], object]) -> tuple[list, threading.Thread, float]:
    """Start ``call`` in a thread: (its answer once it comes, the thread, when it was started)."""
    answer: list = []
    thread = threading.Thread(target=lambda: answer.append(call()), daemon=True)
    started = time.monotonic()
    thread.start()
    return answer, thread, started


def _wait_request(stack, api_id: int, since: float) -> dict:
    """The first request ``api_id`` the robot received since ``since`` (on the record, handled or not)."""
    found: list[dict] = []

    def seen() -> bool:
        found[:] = requests(stack.record.events(since), api_id)
        return bool(found)

    assert wait_until(seen, RECORD_WAIT_S, period_s=0.005), f"api {api_id} never reached the robot"
    return found[0]


def _node_said(stack) -> str:
    """The node's mode, fault and hand-back lines: why it handed the robot back otherwise than asked."""
    words = ("->", "FAULT", "PASSIVE", "lowcmd", "user control", "stale")
    return "\n".join(line for line in stack.node.output().splitlines() if any(w in line for w in words))[-3000:]


def _internal(event: dict) -> InternalCtrl:
    return InternalCtrl(json.loads(event["p"])["data"])


def _estop_inside(stack, interrupted: list, thread: threading.Thread, controller: HoldController) -> tuple[float, object]:
    """Send the e-stop now; (when it was sent, its answer) once the interrupted set_mode answered too."""
    t0 = time.monotonic()
    r = stack.estop()
    print(f"e-stop: {r.message} ({(time.monotonic() - t0) * 1000:.0f} ms)")
    thread.join(RECORD_WAIT_S)
    controller.stop()
    print(f"the interrupted set_mode: {interrupted[0].message if interrupted else 'no answer'}")
    return t0, r


def _user_frames_after_the_stop(ev: list[dict], t0: float) -> list[dict]:
    """User frames the robot handled after the node's first own frame (hold or damping) stamped from ``t0`` on. The
    record holds rt/user_lowcmd in arrival order, which is the order the node sent them in (one writer): a user frame
    the relay wrote before the stop can reach the robot after ``t0``, but not after the node's own frame."""
    frames = [e for _, e in frames_on(ev, "user_lowcmd")]
    first = next((i for i, e in enumerate(frames) if e["t"] >= t0 and e["kp_max"] != USER_KP), None)
    if first is None:  # no own frame after the e-stop: judged by the stamps alone
        return [e for e in frames if e["t"] >= t0 and e["kp_max"] == USER_KP]
    return [e for e in frames[first:] if e["kp_max"] == USER_KP]


def _judge(stack, t0: float, estop, interrupted: list, *, held: dict | None, may_be_user_ctrl: bool) -> list[dict]:
    """What every e-stop inside a step must show on the robot; returns the record.

    ``held``: the step's request the e-stop must land inside (received before its first packet, handled after).
    ``may_be_user_ctrl``: the node had sent or was about to send 7110 (the robot may switch): the user-control
    e-stop's order; where the robot was in user control at the e-stop, a damping frame applied there before PASSIVE.
    A switch that lands after the e-stop shows fsm 1000 for a few ms before PASSIVE, shorter than the relay's damping
    period: printed, not asserted."""
    assert estop.success, estop.message
    assert interrupted and not interrupted[0].success and "preempted by e-stop" in interrupted[0].message, interrupted
    assert wait_until(lambda: fsm_states(stack.record.events())[-1][1] == 1, RECORD_WAIT_S), \
        f"the record's last state is not Damp: {fsm_states(stack.record.events())[-3:]}"
    status = stack.sim.get()
    assert status["sport"]["fsm_id"] == 1 and not status["user_ctrl"], status["sport"]
    ev = stack.record.events()
    after = sorted((e for e in ev if e["t"] >= t0), key=lambda e: e["t"])
    print("on the robot after the e-stop: " + ", ".join(
        f"{e['api']}{e['p'] if e['api'] in (api.LOCO_SET_FSM_ID, api.LOCO_SWITCH_TO_INTERNAL_CTRL) else ''}"
        f"{' noreply' if e['noreply'] else ''} +{(e['t'] - t0) * 1000:.0f} ms" for e in requests(after)
        if e["api"] not in (api.LOCO_GET_FSM_ID, api.MS_CHECK_MODE) and e["svc"] != "voice"))
    print(f"states: {[fsm for _, fsm in fsm_states(ev)][-5:]}")

    shot = next(e for e in requests(after, api.LOCO_SET_FSM_ID) if is_damp(e) and e["noreply"])
    damps = [e for e in requests(after, api.LOCO_SET_FSM_ID) if is_damp(e) and not e["noreply"]]
    if held is not None:  # the e-stop landed inside the step: its first packet between the held call's two ends
        done = next(e for e in requests(ev, held["api"], kind="done") if e["t"] >= held["t"] and e["p"] == held["p"])
        print(f"the held call {held['api']} {held['p']}: received {(held['t'] - t0) * 1000:.0f} ms, handled "
              f"{(done['t'] - t0) * 1000:.0f} ms, the e-stop's DampNoReply {(shot['t'] - t0) * 1000:.0f} ms")
        assert held["t"] <= shot["t"] <= done["t"], "the e-stop did not land inside the held step"

    assert not _user_frames_after_the_stop(ev, t0), "a user frame after the e-stop"
    assert frames_on(ev, "lowcmd") == [], "a frame on rt/lowcmd"
    assert not [e for e in requests(after, api.LOCO_SWITCH_TO_USER_CTRL)], "a SwitchToUserCtrl after the e-stop"
    assert not [e for e in requests(ev) if e["svc"] == "motion_switcher" and e["api"] in MOTION_SWITCHER_CHANGES]
    internal = requests(after, api.LOCO_SWITCH_TO_INTERNAL_CTRL)
    if not may_be_user_ctrl:  # never near user control: the ordinary e-stop, DampNoReply then a Damp
        assert not internal and not frames_on(after, "user_lowcmd"), "user-control traffic from an entry not at its switch"
        assert damps and damps[0]["t"] >= shot["t"]
        return ev
    # a damping frame on rt/user_lowcmd, DampNoReply, SwitchToInternalCtrl(PASSIVE), Damp (docs/user_control.md)
    assert internal and all(_internal(e) is InternalCtrl.PASSIVE for e in internal), [e["p"] for e in internal]
    passive = internal[0]
    damping = [e for _, e in frames_on(after, "user_lowcmd") if e["kp_max"] == 0.0 and e["t"] <= passive["t"]]
    assert damping, "no damping frame on rt/user_lowcmd before SwitchToInternalCtrl(PASSIVE)"
    applied = [f"+{(e['t'] - t0) * 1000:.1f} ms" for e in damping if e["ok"]]
    print(f"first damping frame +{(damping[0]['t'] - t0) * 1000:.1f} ms, first applied {applied[0] if applied else 'none'}, "
          f"PASSIVE +{(passive['t'] - t0) * 1000:.0f} ms")
    shown = [(e["t"], e["fsm"]) for e in of_kind(ev, "state") if e["t"] <= passive["t"]]
    if max((t, fsm) for t, fsm in shown if t < t0)[1] == USER_CTRL_FSM_ID:  # in user control at the e-stop
        assert any(e["ok"] for e in damping), "no damping frame applied while the robot was in user control"
    late = [t for t, fsm in shown if t >= t0 and fsm == USER_CTRL_FSM_ID]
    if late:  # a switch sent before the e-stop landed after it: fsm 1000 until PASSIVE, the relay's damping at 50 Hz
        print(f"a late switch: fsm 1000 for {(passive['t'] - late[0]) * 1000:.0f} ms before PASSIVE, damping frames "
              f"applied meanwhile: {sum(e['ok'] for e in damping)}")
    assert shot["t"] <= passive["t"], "SwitchToInternalCtrl(PASSIVE) before the DampNoReply"
    assert any(e["t"] >= passive["t"] for e in damps), "no Damp after SwitchToInternalCtrl(PASSIVE)"
    return ev


@pytest.mark.parametrize(("target", "hand_back"), [("high_level", InternalCtrl.WALKRUN), ("idle", InternalCtrl.LAST)])
def test_estop_while_the_exit_hand_back_is_in_flight(shared_stack_factory, target: str, hand_back: InternalCtrl) -> None:
    stack, controller = held_in_user_ctrl(shared_stack_factory, faults={"delay_s": {
        str(api.LOCO_SWITCH_TO_INTERNAL_CTRL): STEP_HELD_S}}, node_params=(HELD_CALL,))
    interrupted, thread, requested = _in_background(lambda: stack.set_mode(target))
    held = _wait_request(stack, api.LOCO_SWITCH_TO_INTERNAL_CTRL, requested)
    assert _internal(held) is hand_back, (held, _node_said(stack))
    t0, r = _estop_inside(stack, interrupted, thread, controller)
    ev = _judge(stack, t0, r, interrupted, held=held, may_be_user_ctrl=True)
    # the hand-back in flight landed (7111 cannot be called back): the robot went to its controller, then damping
    fsms = [fsm for _, fsm in fsm_states(ev)]
    print(f"the robot's fsm from user control on: {fsms[fsms.index(USER_CTRL_FSM_ID):]}")


@pytest.mark.parametrize("step", ["rest_wait", "switch_in_flight"])
def test_estop_inside_the_entry_steps(shared_stack_factory, step: str) -> None:
    if step == "rest_wait":  # straight from walking: the robot still steps, the node waits for it to rest
        stack = shared_stack_factory(node_params=(USER_CTRL, STEADY, *REST_HELD))
        marker = api.LOCO_GET_FSM_ID  # the entry's reading of the fsm, right before its rest wait
    else:  # 7110 on the robot, not handled yet (the sim has not accepted it)
        stack = shared_stack_factory(faults={"delay_s": {str(api.LOCO_SWITCH_TO_USER_CTRL): STEP_HELD_S}},
                                     node_params=(USER_CTRL, STEADY, HELD_CALL))
        marker = api.LOCO_SWITCH_TO_USER_CTRL
    controller = HoldController(stack)
    enter_walking(stack, rest=step != "rest_wait")
    controller.start()
    interrupted, thread, requested = _in_background(lambda: stack.set_mode("low_level"))
    held = _wait_request(stack, marker, requested)
    t0, r = _estop_inside(stack, interrupted, thread, controller)
    ev = _judge(stack, t0, r, interrupted, held=held if step == "switch_in_flight" else None,
                may_be_user_ctrl=step == "switch_in_flight")
    if step == "rest_wait":
        assert not frames_on([e for e in ev if e["t"] >= requested], "user_lowcmd"), "a hand-over frame: past the rest wait"
        assert not requests(ev, api.LOCO_SWITCH_TO_USER_CTRL), "a SwitchToUserCtrl: past the rest wait"
        stepping = [e["dq"] for e in of_kind(ev, "body") if e["t"] <= t0][-1]
        print(f"the robot's largest |dq| at the e-stop: {stepping:.2f} rad/s")
