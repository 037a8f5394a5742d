"""LOW_LEVEL by the firmware's user control, the real node against the real sim, judged on the sim's record.

The user's controller and the record's readers are e2e/user_ctrl_session.py's (shared with the e-stops inside
each step of the switch, test_user_ctrl_estop_steps.py).
"""

from __future__ import annotations

import json
import threading
import time

import pytest

from e2e.user_ctrl_session import (
    HOLD_KP,
    STANDING_Z_M,
    STEADY,
    USER_CTRL,
    USER_KP,
    WALKS_M,
    HoldController,
    damped_on_the_record,
    enter_user_ctrl,
    enter_walking,
    frames_on,
    fsm_states,
    held_in_user_ctrl,
    internal_ctrl,
    lowest_pelvis,
    no_user_frame_before_1000,
    wait_sim,
)
from g1_mode_manager.core.user_ctrl import UNSUPPORTED, UserCtrlConfig
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, USER_CTRL_FSM_ID, InternalCtrl
from support.mode_manager import wait_until
from support.sim_record import of_kind, requests
from support.timing import HAND_BACK_S, LOADED_RPC_TIMEOUT_S, RECORD_WAIT_S, check_latency

pytestmark = pytest.mark.e2e

def test_walking_to_user_control_and_back_to_walking(shared_stack_factory) -> None:
    stack = shared_stack_factory(node_params=(USER_CTRL, STEADY))
    controller = HoldController(stack)
    enter_walking(stack)
    start = time.monotonic()
    enter_user_ctrl(stack, controller)
    # held 3 s of sim time: a hold that fails shows within a second (the pelvis drops below standing height as the
    # robot topples), and a longer hold only widens the window for the test's controller to stall on a loaded machine
    wait_sim(stack, 3.0)
    t_out = time.monotonic()
    r = stack.set_mode("high_level")
    print(f"set_mode high_level: {r.message} ({(time.monotonic() - t_out) * 1000:.0f} ms)")
    assert r.success, r.message
    controller.stop()
    walked = stack.walk_forward(0.5, WALKS_M)
    print(f"walked {walked:.2f} m after the hand-back")
    assert walked >= WALKS_M, f"walked only {walked:.2f} m"
    stack.drive_sim_time(0.0, 1.0)

    ev = stack.record.events()
    lowest = lowest_pelvis(ev, start)
    print(f"lowest pelvis {lowest:.3f} m; controller frames {controller.sent}")
    assert lowest > STANDING_Z_M
    no_user_frame_before_1000(ev)
    assert frames_on(ev, "lowcmd") == [], "a frame on rt/lowcmd"
    fsms = [fsm for _, fsm in fsm_states(ev)]
    i_1000 = fsms.index(USER_CTRL_FSM_ID)
    assert fsms[i_1000 + 1] in STANDING_FSM_IDS, fsms  # handed back to the walk-run controller, standing
    assert internal_ctrl(ev) == [InternalCtrl.WALKRUN]
    switcher = [e["api"] for e in requests(ev) if e["svc"] == "motion_switcher" and e["t"] >= start]
    assert api.MS_RELEASE_MODE not in switcher and api.MS_SELECT_MODE not in switcher


def test_controller_heard_late_then_killed_hands_the_robot_back_standing(shared_stack_factory) -> None:
    """The controller's first frame comes 0.4 s after the entry (a ROS publisher made just before its node asks for
    LOW_LEVEL is heard 0.1-0.4 s later): the hand-over frame holds the robot in LOW_LEVEL until then
    (user_ctrl_first_frame_s, wall-clock time as the node's); its silence after the kill hands the robot back
    standing."""
    stack = shared_stack_factory(node_params=(USER_CTRL,))
    controller = HoldController(stack)
    modes = stack.modes()
    enter_walking(stack)
    r = stack.set_mode("low_level")
    assert r.success, r.message
    answered = time.monotonic()
    time.sleep(0.4)  # wall time: on a loaded machine the sim runs slower than the node's clock
    controller.start()
    started = time.monotonic()
    wait_sim(stack, 1.0)  # the user's frames drive the robot (as held_in_user_ctrl holds it) before the kill
    killed = controller.stop()
    assert wait_until(lambda: stack.sim.get()["sport"]["fsm_id"] in STANDING_FSM_IDS, 10.0)
    # standing 3 s of sim time after the hand-back: a robot handed back unbalanced topples within a second, its
    # pelvis below standing height on the record; the walk-run controller's recovery is over in ~0.5 s
    wait_sim(stack, 3.0)
    status = stack.sim.get()
    assert not status["user_ctrl"] and status["sport"]["fsm_id"] in STANDING_FSM_IDS, status["sport"]
    ev = stack.record.events()
    # the silence is judged on the record: on a loaded machine the test's controller may stall past
    # lowcmd_timeout_s before the kill, and then the node rightly hands the robot back at that stall
    entered = next(e["t"] for e in ev if e["k"] == "state" and e["fsm"] == USER_CTRL_FSM_ID)
    back = next(e for e in requests(ev, api.LOCO_SWITCH_TO_INTERNAL_CTRL) if e["t"] >= entered)
    grace_end = entered + UserCtrlConfig().first_frame_s
    driven = [e for _, e in frames_on(ev, "user_lowcmd") if e["kp_max"] == USER_KP]
    print(f"after fsm 1000 on the record: set_mode answered {1000 * (answered - entered):.0f} ms, the controller "
          f"started {1000 * (started - entered):.0f} ms, the hand-back asked {1000 * (back['t'] - entered):.0f} ms")
    if driven:
        # held until the first frame, or until the grace ran out if the test's own thread, starved, sent it later
        held_until = min(driven[0]["t"], grace_end)
        print(f"the controller's first frame {1000 * (driven[0]['t'] - entered):.0f} ms after fsm 1000")
    else:
        # the test's own process, stalled (seconds, seen alone on the machine: the answer reached it after the grace),
        # never got a frame to the robot within the grace: then the promise is the grace held to its end and the
        # robot handed back standing, the controller's late frames refused
        held_until = grace_end
        print("no controller frame within the grace: the robot held for all of it, then handed back")
    assert back["t"] >= held_until, "handed back before the controller's first frame, within the grace"
    held = [e for _, e in frames_on(ev, "user_lowcmd") if entered <= e["t"] < held_until]
    assert held and all(e["kp_max"] == HOLD_KP for e in held), "the robot was not held until the first frame"
    # (a controller stalled from the entry on, which a loaded machine can do to the test's thread, never drove: its silence
    # began at the entry, and the hand-back's count at the grace's end)
    silent_since = max((e["t"] for e in driven if e["t"] <= back["t"]), default=grace_end)
    check_latency("controller silent -> hand-back request on the robot", silent_since, back["t"], HAND_BACK_S)
    print(f"the controller was {'stopped' if silent_since >= killed - 0.05 else 'stalled'} at its last frame")
    assert json.loads(back["p"])["data"] == InternalCtrl.WALKRUN
    lowest = lowest_pelvis(ev, silent_since)
    print(f"lowest pelvis after the silence {lowest:.3f} m")
    assert lowest > STANDING_Z_M
    # until the hand-back the robot got the node's hold frames, never nothing
    after_silence = [e for i, e in frames_on(ev, "user_lowcmd") if silent_since <= e["t"] <= back["t"]]
    assert after_silence and all(e["kp_max"] in (HOLD_KP, USER_KP) for e in after_silence)
    assert wait_until(lambda: modes and modes[-1].name == "IDLE", 5.0), [m.name for m in modes[-3:]]
    said = next(m.last_refusal or m.last_error for m in reversed(modes) if m.name == "IDLE")
    print(f"~/mode after the hand-back: IDLE ({said!r})")
    assert "silent" in said and "walk-run" in said
    assert frames_on(ev, "lowcmd") == []


def test_estop_in_user_control_damps_and_verifies(shared_stack_factory) -> None:
    stack, controller = held_in_user_ctrl(shared_stack_factory)
    t0 = time.monotonic()
    r = stack.estop()
    answered = time.monotonic()
    controller.stop()
    print(f"e-stop: {r.message} ({(answered - t0) * 1000:.0f} ms)")
    assert r.success, r.message

    damping = damped_on_the_record(stack, t0)
    ev = stack.record.events()
    print(f"first damping frame {(damping[0]['t'] - t0) * 1000:.1f} ms after the e-stop call")
    passive = [e for e in requests(ev, api.LOCO_SWITCH_TO_INTERNAL_CTRL) if e["t"] >= t0]
    assert passive and json.loads(passive[0]["p"])["data"] == InternalCtrl.PASSIVE
    assert damping[0]["t"] <= passive[0]["t"], "the damping frame came after PASSIVE"
    last_fsm = fsm_states(ev)[-1][1]
    assert last_fsm == 1 and stack.sim.get()["sport"]["fsm_id"] == 1 and not stack.sim.get()["user_ctrl"]
    user_after = [e for i, e in frames_on(ev, "user_lowcmd") if e["t"] >= answered and e["kp_max"] == USER_KP]
    assert not user_after


def test_estop_inside_the_entry(shared_stack_factory) -> None:
    stack = shared_stack_factory(faults={"user_ctrl_delay_s": 1.5, "delay_s": {"7110": 0.5}},
                                 node_params=(USER_CTRL, STEADY, "user_ctrl_switch_timeout_s:=4.0"))
    controller = HoldController(stack)
    enter_walking(stack)
    controller.start()
    outcome: list = []
    entry = threading.Thread(target=lambda: outcome.append(stack.set_mode("low_level")))
    t_entry = time.monotonic()
    entry.start()
    assert wait_until(lambda: any(e["t"] >= t_entry for e in requests(stack.record.events(),
                                                                      api.LOCO_SWITCH_TO_USER_CTRL, kind="done")), 10.0)
    time.sleep(0.3)  # inside the switch's delay: the robot has accepted, fsm 1000 not shown yet
    t0 = time.monotonic()
    r = stack.estop()
    print(f"e-stop inside the entry: {r.message} ({(time.monotonic() - t0) * 1000:.0f} ms)")
    entry.join(30.0)
    controller.stop()
    assert outcome and not outcome[0].success and "preempted" in outcome[0].message, outcome
    assert r.success, r.message
    # the switch's delay over (the sim's 7110 lands then, whatever came after it): nothing pending can change the
    # robot after this read (the e-stop's answer waits for the landing; a fixed 2 s of sim time waited past it)
    assert wait_until(lambda: not stack.sim.get()["user_ctrl_switching"], RECORD_WAIT_S), "the switch never landed"
    status = stack.sim.get()
    assert status["sport"]["fsm_id"] == 1 and not status["user_ctrl"], status["sport"]
    ev = stack.record.events()
    assert [fsm for _, fsm in fsm_states(ev)][-1] == 1
    assert not [e for _, e in frames_on(ev, "user_lowcmd") if e["kp_max"] == USER_KP and e["ok"]]
    assert frames_on(ev, "lowcmd") == []


def test_firmware_without_user_control_is_refused_with_nothing_changed(shared_stack_factory) -> None:
    stack = shared_stack_factory(faults={"user_ctrl": "none"}, node_params=(USER_CTRL, STEADY))
    assert stack.set_mode("high_level").success
    t0 = time.monotonic()
    r = stack.set_mode("low_level")
    assert not r.success and r.message == UNSUPPORTED, r.message
    time.sleep(0.5)
    ev = [e for e in stack.record.events() if e["t"] >= t0]
    reads = {("sport", api.LOCO_GET_FSM_ID), ("motion_switcher", api.MS_CHECK_MODE)}
    changing = [e for e in requests(ev) if (e["svc"], e["api"]) not in reads and e["svc"] != "voice"]  # voice: LED
    assert [e["api"] for e in changing] == [api.LOCO_SWITCH_TO_USER_CTRL], changing
    assert [e["code"] for e in requests(ev, api.LOCO_SWITCH_TO_USER_CTRL, kind="done")] == [api.ERR_SERVER_API_NOT_IMPL]
    assert not of_kind(ev, "state"), "the robot's state changed"
    frames = [e for _, e in frames_on(ev, "user_lowcmd")]
    assert all(not e["ok"] and e["why"] == "not_user_ctrl" for e in frames)  # the hand-over frame, ignored


def test_node_stopping_in_user_control_hands_the_robot_back(shared_stack_factory) -> None:
    stack, controller = held_in_user_ctrl(shared_stack_factory)
    t0 = time.monotonic()
    code = stack.node.stop()
    print(f"node exit {code} after {(time.monotonic() - t0) * 1000:.0f} ms")
    controller.stop()
    assert code == 0, stack.node.output()[-3000:]
    wait_sim(stack, 3.0)
    status = stack.sim.get()
    assert not status["user_ctrl"] and status["sport"]["fsm_id"] in STANDING_FSM_IDS, status["sport"]
    ev = stack.record.events()
    back = [e for e in requests(ev, api.LOCO_SWITCH_TO_INTERNAL_CTRL) if e["t"] >= t0]
    assert back and json.loads(back[0]["p"])["data"] == InternalCtrl.WALKRUN
    assert lowest_pelvis(ev, t0) > STANDING_Z_M


def test_remote_l2_b_in_user_control_damps_the_robot(shared_stack_factory) -> None:
    stack, controller = held_in_user_ctrl(shared_stack_factory)
    modes = stack.modes()
    t0 = time.monotonic()
    stack.set_faults({"remote_keys": ["L2", "B"]})  # the firmware ignores the remote in user control; the node not
    assert wait_until(lambda: modes and modes[-1].name == "EMERGENCY" and modes[-1].damp_confirmed, 15.0), \
        [(m.name, m.damp_confirmed) for m in modes[-3:]]
    controller.stop()
    stack.set_faults({})
    # the sim's frame handler may lag its reader on a loaded machine: wait for the record
    assert wait_until(lambda: any(e["kp_max"] == 0.0 for _, e in frames_on(stack.record.events(t0), "user_lowcmd")),
                      RECORD_WAIT_S), "no damping frame on rt/user_lowcmd after L2+B"
    ev = [e for e in stack.record.events() if e["t"] >= t0]
    damping = [e for _, e in frames_on(ev, "user_lowcmd") if e["kp_max"] == 0.0]
    passive = [e for e in requests(ev, api.LOCO_SWITCH_TO_INTERNAL_CTRL)]
    assert damping and passive and json.loads(passive[0]["p"])["data"] == InternalCtrl.PASSIVE
    print(f"L2+B: first damping frame {(damping[0]['t'] - t0) * 1000:.0f} ms, PASSIVE {(passive[0]['t'] - t0) * 1000:.0f} "
          "ms after the keys were set")
    assert stack.sim.get()["sport"]["fsm_id"] == 1 and not stack.sim.get()["user_ctrl"]


def test_from_a_damped_robot_and_back_to_damping_by_last(shared_stack_factory) -> None:
    # in the gantry, as Unitree's user-control example is run: a damped G1 standing free sinks to the floor, where
    # LOW_LEVEL's fall check (the user's controller is responsible for keeping it up) would FAULT at once
    stack = shared_stack_factory(node_params=(USER_CTRL, STEADY, f"rpc_timeout_s:={LOADED_RPC_TIMEOUT_S}"),
                                 bridge_args=("--gantry",))
    controller = HoldController(stack)
    assert stack.set_mode("high_level").success
    assert stack.loco("damp").success
    wait_sim(stack, 3.0)  # damping: the robot sinks and comes to rest
    assert stack.set_mode("idle").success
    enter_user_ctrl(stack, controller)
    wait_sim(stack, 1.0)
    r = stack.set_mode("idle")
    print(f"set_mode idle: {r.message}")
    assert r.success and "fsm 1 seen" in r.message, r.message
    controller.stop()
    ev = stack.record.events()
    fsms = [fsm for _, fsm in fsm_states(ev)]
    i = fsms.index(USER_CTRL_FSM_ID)
    assert fsms[i - 1] == 1 and fsms[i + 1] == 1, fsms  # from damping, back to damping
    assert internal_ctrl(ev) == [InternalCtrl.LAST]
    no_user_frame_before_1000(ev)
    assert frames_on(ev, "lowcmd") == []


def test_entry_straight_from_walking_waits_for_rest(shared_stack_factory) -> None:
    stack = shared_stack_factory(node_params=(USER_CTRL,))
    enter_walking(stack, rest=False)
    t0 = time.monotonic()
    r = stack.set_mode("low_level")  # no controller: handed back once the entry is done (silence)
    print(f"set_mode low_level straight from walking: {r.message} ({(time.monotonic() - t0) * 1000:.0f} ms)")
    assert r.success, r.message
    wait_sim(stack, 3.0)
    ev = stack.record.events()
    switch = next(e for e in requests(ev, api.LOCO_SWITCH_TO_USER_CTRL) if e["t"] >= t0)
    body = [e for e in of_kind(ev, "body") if t0 <= e["t"] <= switch["t"]]
    print(f"7110 sent {(switch['t'] - t0) * 1000:.0f} ms after the request; largest |dq| meanwhile "
          f"{max(e['dq'] for e in body):.2f} rad/s, at the switch {body[-1]['dq']:.2f} rad/s")
    # the node judged rest on a frame it read before sending 7110; the record samples every 10 ms of sim time, so
    # the robot at rest shows in one of the last samples before the switch, not always in the very last
    assert min(e["dq"] for e in body[-3:]) <= UserCtrlConfig().rest_speed_rad_s, [e["dq"] for e in body[-5:]]
    assert lowest_pelvis(ev, t0) > STANDING_Z_M
    assert stack.sim.get()["sport"]["fsm_id"] in STANDING_FSM_IDS

