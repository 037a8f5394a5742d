"""Faults inside the node's policy loop mid-walk, each made true on the real sim: a policy whose actions turn
non-finite, one whose inference turns slow, and the robot's state stream frozen. Each ends with the policy's frames
stopped, the robot held, then handed back by the user-control rules (WALKRUN and standing when upright; PASSIVE,
FAULT and damped when not), and no bad frame on the record."""

from __future__ import annotations

import json
import time

import pytest
from g1_mode_manager_msgs.msg import Mode as ModeMsg

from e2e.test_policy import POLICY_KP_MAX, STEADY_POLICY, engage, statuses
from e2e.user_ctrl_session import HOLD_KP, STANDING_Z_M, USER_CTRL, frames_on, fsm_states
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, InternalCtrl
from support import faulty_policies
from support.mode_manager import wait_until
from support.sim_record import is_damp, of_kind, requests
from support.timing import POLICY_OVERRUN_TEST_S, RECORD_WAIT_S

pytestmark = [pytest.mark.e2e, pytest.mark.policy_faults]

#: The teleop's speed once walking: past the faulty policies' FAIL_ABOVE_MPS.
SPEED = 0.6


def policy_frames(ev) -> list[dict]:
    return [e for _, e in frames_on(ev, "user_lowcmd") if abs(e["kp_max"] - POLICY_KP_MAX) < 1e-3]


def handed_back_by_the_rules(stack, since: float) -> int:
    """The robot was handed back after the policy's last frame, by the user-control rules, with no bad frame on
    the record; returns the InternalCtrl it was handed back with."""
    assert wait_until(lambda: [e for e in requests(stack.record.events(), api.LOCO_SWITCH_TO_INTERNAL_CTRL)
                               if e["t"] >= since], RECORD_WAIT_S), "the robot was never handed back"
    time.sleep(0.5)  # the hand-back's last steps reach the record
    ev = stack.record.events()
    switch = next(e for e in requests(ev, api.LOCO_SWITCH_TO_INTERNAL_CTRL) if e["t"] >= since)
    target = json.loads(switch["p"])["data"]
    ours = [e for _, e in frames_on(ev, "user_lowcmd") if e["t"] >= since]
    policy = policy_frames(ev)
    assert policy and policy[-1]["t"] < switch["t"], "a policy frame at or after the hand-back"
    after = [e for e in ours if policy[-1]["t"] < e["t"] < switch["t"]]
    assert after and all(e["kp_max"] in (HOLD_KP, 0.0) for e in after), "no hold or damping between the policy and " \
        "the hand-back"
    # a bad frame is one the robot refused as such (CRC, content); a hold arriving as the robot leaves user control
    # is ignored as not_user_ctrl, which is the robot's state, not the frame's
    bad = [(e["why"], e["crc"], e["kp_max"]) for e in ours if e["crc"] != "ok" or e["why"] not in (None, "not_user_ctrl")]
    assert not bad, bad[:5]
    if target == InternalCtrl.WALKRUN:
        # handed back upright: the robot's own controller stands it, or, when the failing policy left it falling
        # (a stall of 0.2 s mid-step can), the tilt check's FAULT damps it; either way the robot is held
        def held() -> bool:
            fsm = fsm_states(stack.record.events())[-1][1]
            return fsm in STANDING_FSM_IDS or (fsm == 1 and stack.sim.get()["sport"]["fsm_id"] == 1)

        assert wait_until(held, RECORD_WAIT_S), fsm_states(stack.record.events())[-3:]
    else:
        assert target == InternalCtrl.PASSIVE
        assert wait_until(lambda: stack.sim.get()["sport"]["fsm_id"] == 1, RECORD_WAIT_S), "tilted, not damped"
    return target


def drive_until_the_loop_stops(stack, vx: float) -> str:
    seen = statuses(stack)
    stack.drive_sim_time(0.2, 1.0)
    end = time.monotonic() + RECORD_WAIT_S
    while time.monotonic() < end and seen[-1].phase == "running":
        stack.drive(vx, 0.2)
    assert seen[-1].phase == "loaded", f"the policy is {seen[-1].phase}"
    return seen[-1].last_fault


@pytest.mark.parametrize("fault", ["nan", "overrun"])
def test_a_policy_that_fails_mid_walk_is_stopped_and_the_robot_handed_back(shared_stack_factory, tmp_path,
                                                                             fault) -> None:
    params = STEADY_POLICY
    if fault == "nan":
        model = faulty_policies.nan_when_fast(tmp_path / "nan.onnx")
    else:  # ticks of twice the loop's overrun bound past FAIL_ABOVE_MPS, far shorter than the relay's silence
        model = faulty_policies.slow_when_fast(tmp_path / "slow.onnx", tick_s=2 * POLICY_OVERRUN_TEST_S)
        # the first overrun stops the policy (the count in a row is the unit tests'): a walker that stalls three
        # times proposes wild targets, which the frame check would stop first
        params = (*STEADY_POLICY, f"policy_overrun_s:={POLICY_OVERRUN_TEST_S}", "policy_max_overruns:=1")
    stack = shared_stack_factory(node_params=params)
    engage(stack, str(faulty_policies.deploy_config(model, tmp_path / "policy.yaml")), shadow_s=1.0)
    since = time.monotonic()
    why = drive_until_the_loop_stops(stack, SPEED)
    print(f"the loop stopped the policy: {why}")
    assert ("non-finite" if fault == "nan" else "ticks in a row over") in why
    print(f"handed back with {InternalCtrl(handed_back_by_the_rules(stack, since)).name}")


def test_a_frozen_state_stream_mid_walk_ends_one_way_with_the_default_parameters(shared_stack_factory) -> None:
    """Every parameter at its default (user control): the stream stops, the policy stops on a sample older than
    policy_state_timeout_s, the robot is held, and the hand-back, decided by the robot's last attitude (upright, at
    most HAND_BACK_ATTITUDE_S old), gives it back to its walk-run controller: LOW_LEVEL -> IDLE, no FAULT, no Damp,
    standing. Judged on the sim's record; /diagnostics says why the policy stopped."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

    stack = shared_stack_factory(node_params=(USER_CTRL,))
    stack.modes()  # subscribed from the start
    diagnostics: list = []
    stack.ros.node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
    engage(stack, shadow_s=1.0)
    stack.drive_sim_time(0.4, 1.0)
    since = time.monotonic()
    stack.set_faults({"freeze_lowstate": True})
    frozen = next(e["t"] for e in of_kind(stack.record.events(since), "inject") if e["what"] == "freeze_lowstate")
    assert wait_until(lambda: statuses(stack)[-1].phase == "loaded", RECORD_WAIT_S)
    why = statuses(stack)[-1].last_fault
    print(f"the loop stopped the policy: {why}")
    assert "state sample" in why
    assert handed_back_by_the_rules(stack, since) == InternalCtrl.WALKRUN
    ev = stack.record.events(since)
    switch = next(e for e in requests(ev, api.LOCO_SWITCH_TO_INTERNAL_CTRL))
    print(f"freeze -> SwitchToInternalCtrl(WALKRUN) on the record: {(switch['t'] - frozen) * 1e3:.0f} ms")
    assert wait_until(lambda: fsm_states(stack.record.events(since))[-1][1] in STANDING_FSM_IDS, RECORD_WAIT_S)
    assert not [e for e in requests(stack.record.events(since)) if is_damp(e)], "the robot was damped"
    assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.IDLE, RECORD_WAIT_S), stack.modes()[-1]
    assert stack.sim.get()["body"]["pelvis_z"] > STANDING_Z_M, "the robot did not stand under its own controller"

    def policy_warns() -> bool:
        return any(st.name == "g1_mode_manager: policy" and st.level == DiagnosticStatus.WARN
                   and "state sample" in st.message for array in diagnostics for st in array.status)

    assert wait_until(policy_warns, RECORD_WAIT_S), "/diagnostics does not say why the policy stopped"
