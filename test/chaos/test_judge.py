"""The chaos judge on made-up records (no sim), where robot-side times meet the test's receive times of ~/mode: a
claim arrives a little after what it says has reached the robot."""

from __future__ import annotations

import json
from types import SimpleNamespace

from chaos.scenario import FAULT_DAMPED_S, GRACE_S, HOLD_KP, Claims, judge
from g1_mode_manager.protocol import api_ids

IDLE, HIGH_LEVEL, LOW_LEVEL, EMERGENCY, FAULT = 1, 2, 3, 4, 5
END = {"sport": {"fsm_id": 1, "mode": "ai"}}


def _state(t: float, fsm: int) -> dict:
    return {"k": "state", "t": t, "fsm": fsm, "svc": "ai", "fsm_mode": 0}


def _damp(t: float, noreply: bool) -> dict:
    return {"k": "req", "t": t, "svc": "sport", "api": api_ids.LOCO_SET_FSM_ID, "p": json.dumps({"data": 1}),
            "noreply": noreply}


def _mode(mode: int, damp_confirmed: bool = False, transition: bool = False) -> SimpleNamespace:
    return SimpleNamespace(mode=mode, name=str(mode), damp_confirmed=damp_confirmed, holds=[],
                           transition_in_progress=transition)


def _claims(t_fault: float, t_estop: float) -> Claims:
    claims = Claims(t_estop=t_estop)
    claims.modes = [(1.0, _mode(HIGH_LEVEL)), (t_fault, _mode(FAULT)), (t_fault + 0.5, _mode(FAULT, True)),
                    (t_estop + 0.01, _mode(EMERGENCY, True))]
    return claims


def _record(damped_at: float | None, t_estop: float) -> list[dict]:
    events = [_state(0.0, 4)]
    if damped_at is not None:
        events += [_damp(damped_at - 0.001, True), _state(damped_at, 1)]
    events += [_damp(t_estop + 0.001, True), _damp(t_estop + 0.002, False)]
    if damped_at is None:
        events.append(_state(t_estop + 0.003, 1))
    return [*events, {"k": "body", "t": t_estop + 1.0}]


def test_a_robot_damped_just_before_the_claim_arrives_was_seen_damped() -> None:
    # the protective stop's Damp reached the robot 2 ms before the test received ~/mode saying FAULT
    t_fault, t_estop = 10.0, 10.0 + FAULT_DAMPED_S + 5.0
    assert judge(_record(t_fault - 0.002, t_estop), _claims(t_fault, t_estop), END) == []


def test_a_robot_never_damped_in_fault_is_a_violation() -> None:
    t_fault, t_estop = 10.0, 10.0 + FAULT_DAMPED_S + 5.0
    assert f"robot not damped within {FAULT_DAMPED_S} s of FAULT" in judge(_record(None, t_estop), _claims(t_fault, t_estop), END)


def _lowcmd(t: float) -> dict:
    return {"k": "frame", "t": t, "topic": "lowcmd", "ok": True, "why": None, "w": 0.0, "kp_max": 40.0, "crc": "ok"}


def _low_level_again(first_frame_after_claim_s: float) -> list[str]:
    """LOW_LEVEL, left to IDLE at 5, entered again at 10 (its claim received at 10.0); the user's stream runs on."""
    t_estop = 20.0
    claims = Claims(t_estop=t_estop)
    claims.modes = [(1.0, _mode(LOW_LEVEL)), (5.0, _mode(LOW_LEVEL, transition=True)), (5.01, _mode(IDLE)),
                    (9.9, _mode(IDLE, transition=True)), (10.0, _mode(LOW_LEVEL)), (t_estop + 0.01, _mode(EMERGENCY, True))]
    frames = [_lowcmd(10.0 + first_frame_after_claim_s + 0.01 * k) for k in range(10)]
    events = [_state(0.0, 0), *frames, _damp(t_estop + 0.001, True), _damp(t_estop + 0.002, False), _state(t_estop + 0.003, 1)]
    return judge(events, claims, END)


def test_a_user_frame_that_reaches_the_robot_before_the_low_level_claim_reaches_the_test_is_not_late() -> None:
    assert _low_level_again(-GRACE_S / 2) == []  # the node is in LOW_LEVEL: its claim is still on its way


def test_a_user_frame_between_leaving_low_level_and_entering_it_again_is_a_violation() -> None:
    bad = _low_level_again(-2.0)
    assert len(bad) == 1 and bad[0].startswith("user lowcmd frame (kp 40.0) 3.000 s after leaving LOW_LEVEL"), bad


def test_a_successors_low_level_frames_are_not_judged_in_the_killed_nodes_life() -> None:
    # the node leaves LOW_LEVEL at 5 and is SIGKILLed at 8; its successor enters LOW_LEVEL at 12 and streams
    t_estop = 20.0
    claims = Claims(t_estop=t_estop)
    claims.modes = [(1.0, _mode(LOW_LEVEL)), (5.0, _mode(LOW_LEVEL, transition=True)), (5.01, _mode(IDLE)),
                    (9.5, _mode(0)), (11.9, _mode(IDLE, transition=True)), (12.0, _mode(LOW_LEVEL)),
                    (t_estop + 0.01, _mode(EMERGENCY, True))]
    claims.restarts = [(8.0, 9.0)]
    frames = [_lowcmd(12.1 + 0.01 * k) for k in range(10)]
    events = [_state(0.0, 0), *frames, _damp(t_estop + 0.001, True), _damp(t_estop + 0.002, False), _state(t_estop + 0.003, 1)]
    assert [why for why in judge(events, claims, END) if "after leaving LOW_LEVEL" in why] == []
    # a frame in the killed node's own life, after it left LOW_LEVEL, is still flagged
    events.insert(1, _lowcmd(7.0))
    bad = [why for why in judge(events, claims, END) if "after leaving LOW_LEVEL" in why]
    assert len(bad) == 1 and bad[0].startswith("user lowcmd frame (kp 40.0) 2.000 s after leaving LOW_LEVEL"), bad


def _user_ctrl_record(*frames: dict, svc: str = "ai") -> list[dict]:
    """Standing, under user control from 2.0 to 5.0, e-stopped at 20.0."""
    t_estop = 20.0
    return [_state(0.0, 500), {**_state(2.0, 1000), "svc": svc}, _state(5.0, 500), *frames,
            _damp(t_estop + 0.001, True), _damp(t_estop + 0.002, False), _state(t_estop + 0.003, 1)]


def _user_lowcmd(t: float, kp: float, why: str | None = None) -> dict:
    return {**_lowcmd(t), "topic": "user_lowcmd", "kp_max": kp, "ok": why is None, "why": why}


def test_on_the_user_ctrl_path_the_hand_over_before_the_switch_and_the_users_frames_inside_it_are_clean() -> None:
    frames = [_user_lowcmd(1.9, HOLD_KP, "not_user_ctrl"), *(_user_lowcmd(2.1 + 0.01 * k, 40.0) for k in range(10))]
    assert judge(_user_ctrl_record(*frames), Claims(t_estop=20.0), END, path="user_ctrl") == []


def test_on_the_user_ctrl_path_a_user_frame_outside_user_control_is_a_violation() -> None:
    bad = judge(_user_ctrl_record(_user_lowcmd(1.95, 40.0, "not_user_ctrl")), Claims(t_estop=20.0), END,
                path="user_ctrl")
    assert len(bad) == 1 and bad[0].startswith("a user frame (kp 40.0) reached the robot outside user control"), bad


def test_on_the_user_ctrl_path_a_released_robot_or_a_frame_on_rt_lowcmd_is_a_violation() -> None:
    release = {"k": "req", "t": 1.0, "svc": "motion_switcher", "api": api_ids.MS_RELEASE_MODE, "p": "{}",
               "noreply": False}
    bad = judge([release, *_user_ctrl_record(svc="")], Claims(t_estop=20.0), END, path="user_ctrl")
    assert any(why.startswith("ReleaseMode on the user_ctrl path") for why in bad), bad
    assert any(why.startswith("the robot released (limp) on the user_ctrl path") for why in bad), bad
    damping = {**_lowcmd(3.0), "kp_max": 0.0}
    bad = judge(_user_ctrl_record(damping), Claims(t_estop=20.0), END, path="user_ctrl")
    assert len(bad) == 1 and bad[0].startswith("a frame on rt/lowcmd on the user_ctrl path"), bad


def test_on_the_release_path_a_frame_on_rt_user_lowcmd_is_a_violation() -> None:
    bad = judge(_user_ctrl_record(_user_lowcmd(3.0, 0.0)), Claims(t_estop=20.0), END, path="release")
    assert len(bad) == 1 and bad[0].startswith("a frame on rt/user_lowcmd on the release path"), bad


def test_a_hold_frame_after_the_estop_is_a_violation_and_after_leaving_low_level_is_not() -> None:
    claims = Claims(t_estop=20.0)
    claims.modes = [(2.1, _mode(LOW_LEVEL)), (4.0, _mode(LOW_LEVEL, transition=True)), (5.1, _mode(HIGH_LEVEL)),
                    (20.01, _mode(EMERGENCY, True))]
    holds = [_user_lowcmd(4.0 + 0.02 * k, HOLD_KP) for k in range(50)]  # the hand-back's hold, until fsm 500 shows
    assert judge(_user_ctrl_record(*holds), claims, END, path="user_ctrl") == []
    bad = judge(_user_ctrl_record(*holds, _user_lowcmd(20.5, HOLD_KP, "not_user_ctrl")), claims, END, path="user_ctrl")
    assert bad == [f"user_lowcmd frame (kp {HOLD_KP}) after the e-stop"], bad
    bad = judge(_user_ctrl_record(_user_lowcmd(4.5, 40.0)), claims, END, path="user_ctrl")
    assert len(bad) == 1 and "s after leaving LOW_LEVEL" in bad[0], bad
