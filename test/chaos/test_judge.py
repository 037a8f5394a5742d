"""The chaos judge on made-up records (no sim), where robot-side times meet the test's receive times of ~/mode: a
claim arrives a little after what it says has reached the robot."""

from __future__ import annotations

import json
from types import SimpleNamespace

from chaos.coverage import (
    AUTONOMY_SILENT,
    ESTOP_WHILE_AUTONOMY,
    HAND_OVER,
    HAND_OVER_REFUSED,
    LEFT_WHILE_AUTONOMY,
    TAKE_OVER_SERVICE,
    TAKEOVER_BY_TELEOP,
)
from chaos.drivers import AUTONOMY_TIMEOUT_S, Call, DriveLog, drive_cells, judge_drivers
from chaos.scenario import FAULT_DAMPED_S, GRACE_S, HOLD_KP, Claims, judge
from g1_mode_manager.protocol import api_ids
from support.timing import SILENT_PLANNER_STOP_S

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



def test_a_user_frame_late_in_flight_before_the_nodes_exit_frames_is_not_after_leaving_low_level() -> None:
    claims = Claims(t_estop=20.0)
    claims.modes = [(2.1, _mode(LOW_LEVEL)), (4.0, _mode(LOW_LEVEL, transition=True)), (5.1, _mode(IDLE)),
                    (20.01, _mode(EMERGENCY, True))]
    late = _user_lowcmd(4.0 + 2 * GRACE_S, 40.0)  # sent before the leave, delayed on a loaded machine
    exit_frames = [_user_lowcmd(4.0 + 2 * GRACE_S + 0.001 + 0.02 * k, HOLD_KP) for k in range(5)]
    assert judge(_user_ctrl_record(late, *exit_frames), claims, END, path="user_ctrl") == []
    # the same user frame after the node's own exit frames was sent after the leave
    early_exit = [_user_lowcmd(3.99 + 0.02 * k, HOLD_KP) for k in range(2)]
    bad = judge(_user_ctrl_record(*early_exit, late, *exit_frames), claims, END, path="user_ctrl")
    assert len(bad) == 1 and "s after leaving LOW_LEVEL" in bad[0], bad


# --- who drives: the planner's Moves only while handed the robot, within the autonomy's limits -----------------
COMMAND = (0.7, 0.4, -1.0)  # past every autonomy limit (0.5, 0.3, 0.8): the node clamps it


def _move(t: float, v: tuple[float, float, float]) -> list[dict]:
    """A Move the robot received at ``t`` and acknowledged."""
    p = json.dumps({"velocity": list(v), "duration": 1.0})
    return [{"k": "req", "t": t, "svc": "sport", "api": api_ids.LOCO_SET_VELOCITY, "p": p, "noreply": False},
            {"k": "done", "t": t + 0.001, "svc": "sport", "api": api_ids.LOCO_SET_VELOCITY, "p": p, "code": 0}]


def _planner(t0: float, n: int = 10) -> list[dict]:
    """The planner's Moves as the node ramps them, every 50 ms from standstill: (vx, vy, wz) by the autonomy's
    acceleration limits (1.0, 0.7, 2.0 over 50 ms) toward its clamped command."""
    v = [(min(0.05 * k, 0.5), min(0.035 * k, 0.3), -min(0.1 * k, 0.8)) for k in range(1, n + 1)]
    return [e for k, each in enumerate(v, 1) for e in _move(t0 + 0.05 * k, each)]


def _teleop(t0: float, n: int = 5) -> list[dict]:
    return [e for k in range(1, n + 1) for e in _move(t0 + 0.05 * k, (min(0.075 * k, 0.3), 0.0, 0.0))]


def _drive_mode(mode: int = HIGH_LEVEL, driver: str = "teleop", transition: bool = False, target: int = 0,
                suspended: str = "") -> SimpleNamespace:
    return SimpleNamespace(mode=mode, name=str(mode), damp_confirmed=mode == EMERGENCY, holds=[],
                           transition_in_progress=transition, transition_target=target, driver=driver,
                           autonomy_suspended=suspended)


def _judged_drive(*moves: list[dict], hand_overs=(), take_overs=(), modes=(), restarts=(), streams=()) -> list[str]:
    """Judged as a chaos scenario with a planner, in HIGH_LEVEL from 1.0 (unless ``modes``), e-stopped at 20.0."""
    log = DriveLog(planner_command=COMMAND, hand_overs=list(hand_overs), take_overs=list(take_overs),
                   planner_streams=[list(s) for s in streams] or [[0.5, 19.9]])
    claims = Claims(t_estop=20.0, drives=log, restarts=list(restarts),
                    modes=[*(modes or [(1.0, _drive_mode())]), (20.01, _drive_mode(EMERGENCY, "nobody"))])
    events = [_state(0.0, 500), *(e for each in moves for e in each), _damp(20.001, True), _damp(20.002, False),
              _state(20.003, 1)]
    return judge(sorted(events, key=lambda e: e["t"]), claims, END)


def test_planner_moves_after_the_hand_over_was_requested_are_clean_and_before_it_a_violation() -> None:
    handed = Call(sent=5.0, answered=5.02, success=True)
    # the node handed over at once: its first Move reached the robot before the test had the answer
    assert _judged_drive(_planner(4.96), hand_overs=[handed]) == []
    bad = _judged_drive(_planner(3.0), hand_overs=[handed])
    assert len(bad) == 1 and bad[0].endswith("no hand-over that succeeded was requested before it"), bad
    refused = Call(sent=2.0, answered=2.01, success=False, message="mode is IDLE")
    bad = _judged_drive(_planner(3.0), hand_overs=[refused])
    assert len(bad) == 1 and "no hand-over that succeeded" in bad[0], bad


def test_a_teleop_move_takes_the_robot_until_the_next_hand_over() -> None:
    handed = [Call(5.0, 5.01, True), Call(9.0, 9.01, True)]
    clean = _judged_drive(_planner(5.0), _teleop(6.0), _planner(9.0), hand_overs=handed)
    assert clean == [], clean
    bad = _judged_drive(_planner(5.0), _teleop(6.0), _planner(7.0), hand_overs=handed)
    assert len(bad) == 1 and "the teleop's Move at 6.050 ended the autonomy's drive" in bad[0], bad
    # a teleop Move the node wrote before it handed over (on the record just after the answer) takes nothing
    assert _judged_drive(_teleop(4.96, 1), _planner(5.1), hand_overs=handed[:1]) == []


def test_take_over_and_leaving_high_level_and_a_restart_end_the_planners_drive() -> None:
    handed = [Call(5.0, 5.01, True)]
    taken = Call(8.0, 8.01, True, "the teleop drives; the autonomy needs a new hand-over")
    # a Move in flight when the take-over was answered is not late; one after it is
    assert _judged_drive(_planner(5.0, 60), take_overs=[Call(8.0, 8.0, True)], hand_overs=handed) == []
    bad = _judged_drive(_planner(5.0, 80), take_overs=[taken], hand_overs=handed)
    assert len(bad) == 1 and "~/take_over answered at 8.010 ended" in bad[0], bad
    left = [(1.0, _drive_mode()), (5.02, _drive_mode(driver="autonomy")),
            (7.0, _drive_mode(transition=True, target=IDLE, driver="autonomy")), (7.1, _drive_mode(IDLE, "nobody")),
            (8.0, _drive_mode(IDLE, "nobody", transition=True, target=HIGH_LEVEL)), (8.5, _drive_mode())]
    stop = _move(7.05, (0.0, 0.0, 0.0))  # leaving HIGH_LEVEL, the node stops the robot
    bad = _judged_drive(_planner(5.0, 20), stop, _planner(9.0), hand_overs=handed, modes=left)
    assert len(bad) == 1 and "leaving HIGH_LEVEL (2) claimed at 7.000 ended" in bad[0], bad
    bad = _judged_drive(_planner(5.0, 20), _planner(9.0), hand_overs=handed, restarts=[(7.5, 8.0)])
    assert any("the node stopped at 7.500 ended" in why for why in bad), bad


def test_a_planner_move_is_judged_by_when_the_node_sent_it_not_when_a_starved_robot_received_it() -> None:
    handed = [Call(5.0, 5.01, True)]
    left = [(1.0, _drive_mode()), (5.02, _drive_mode(driver="autonomy")), (7.0, _drive_mode(IDLE, "nobody"))]

    def received_late(sent: float) -> list[dict]:
        # the ramp's next Move, stamped by the SDK as the node built it, reached the robot 0.1 s after the claim
        late = _move(7.1, (0.5, 0.3, -0.8))
        late[0]["id"] = int(sent * 1e9)
        return late

    assert _judged_drive(_planner(5.0, 39), received_late(6.99), hand_overs=handed, modes=left) == []
    bad = _judged_drive(_planner(5.0, 39), received_late(7.08), hand_overs=handed, modes=left)
    assert len(bad) == 1 and "was sent at 7.080: leaving HIGH_LEVEL (1) claimed at 7.000 ended" in bad[0], bad


def test_planner_moves_past_the_autonomys_limits_or_its_command_are_violations() -> None:
    handed = [Call(5.0, 5.01, True)]
    ramp = _planner(5.0)
    # ramped on past the autonomy's 0.5 m/s toward the command's 0.7, as the teleop's limits would let it
    bad = _judged_drive(ramp, _move(5.6, (0.55, 0.3, -0.8)), hand_overs=handed)
    assert bad == ["a planner Move [0.55, 0.3, -0.8] at 5.600 above the autonomy's limits (0.5, 0.3, 0.8)"], bad
    log_command = (0.3, 0.4, -1.0)  # asked for 0.3 m/s ahead: a Move of 0.5 is more than it asked
    claims_bad = judge_drivers([e for e in ramp if e["k"] == "req"], [], DriveLog(log_command, [Call(5.0, 5.01, True)]),
                               [], GRACE_S)
    assert len(claims_bad) == 1 and "above what the planner asked, (0.3, 0.4, -1.0)" in claims_bad[0], claims_bad


def test_a_move_of_neither_shape_and_a_planner_step_past_its_own_acceleration_are_violations() -> None:
    handed = [Call(5.0, 5.01, True)]
    bad = _judged_drive(_move(5.5, (0.2, 0.0, -0.3)), hand_overs=handed)
    assert bad == ["a Move [0.2, 0.0, -0.3] at 5.500 of neither the teleop's shape nor the planner's"], bad
    # vy 0.05 from standstill: within the teleop's acceleration (1.0 over 50 ms), past the autonomy's (0.7)
    bad = _judged_drive(_move(5.5, (0.05, 0.05, -0.1)), hand_overs=handed)
    assert bad == ["planner Move [0.05, 0.05, -0.1] after [0.0, 0.0, 0.0]: above its acceleration limit"], bad
    # the teleop at 0.3 and the planner from standstill: a change of driver starts the ramp again
    assert _judged_drive(_teleop(4.0), _planner(5.0), hand_overs=handed) == []
    # in mid-ramp, a step of 0.07 m/s ahead: within the teleop's 0.075 per step, past the autonomy's 0.05
    bad = _judged_drive(_planner(5.0, 3), _move(5.2, (0.22, 0.14, -0.4)), hand_overs=handed)
    assert len(bad) == 1 and bad[0].startswith("planner Move [0.22, 0.14, -0.4] after [0.15"), bad


def test_a_silent_planners_moves_after_its_timeout_and_margin_are_violations() -> None:
    handed = [Call(5.0, 5.01, True)]
    assert _judged_drive(_planner(5.0, 20), hand_overs=handed, streams=[(4.0, 5.5), (7.0, 19.0)]) == []
    late = 5.5 + AUTONOMY_TIMEOUT_S + SILENT_PLANNER_STOP_S + 0.1
    bad = _judged_drive(_planner(late - 0.05, 1), hand_overs=handed, streams=[(4.0, 5.5), (9.0, 19.0)])
    assert len(bad) == 1 and "after the planner fell silent" in bad[0], bad


def test_without_a_planner_every_move_is_the_teleops_as_in_the_soak() -> None:
    claims = Claims(t_estop=20.0)
    events = [_state(0.0, 500), *_move(5.0, (0.05, -0.04, 0.1)), _damp(20.001, True), _damp(20.002, False),
              _state(20.003, 1)]
    assert judge(events, claims, END) == []


def test_drive_cells_name_what_the_scenario_showed() -> None:
    silent = "silent: no cmd_vel_nav for 0.5 s"
    modes = [(1.0, _drive_mode()), (5.02, _drive_mode(driver="autonomy")), (6.06, _drive_mode()),
             (9.02, _drive_mode(driver="autonomy")), (10.0, _drive_mode(driver="autonomy", suspended=silent)),
             (19.0, _drive_mode(driver="autonomy"))]
    log = DriveLog(COMMAND, [Call(2.0, 2.01, False), Call(5.0, 5.01, True), Call(9.0, 9.01, True)],
                   [Call(8.0, 8.01, True, "the teleop drives already")])
    events = [*_planner(5.0), *_teleop(6.0), *_planner(9.0, 5), *_move(10.0, (0.0, 0.0, 0.0)), *_planner(19.0)]
    cells = drive_cells(sorted(events, key=lambda e: e["t"]), modes, log, t_estop=20.0)
    assert cells == [HAND_OVER, HAND_OVER_REFUSED, TAKEOVER_BY_TELEOP, AUTONOMY_SILENT, ESTOP_WHILE_AUTONOMY], cells
    # "silent" the moment after a hand-over, before the planner's first command reached the node, is no silence
    transient = [(9.012, _drive_mode(driver="autonomy", suspended=silent)) if t == 10.0 else (t, m) for t, m in modes]
    cells = drive_cells(sorted(events, key=lambda e: e["t"]), transient, log, t_estop=20.0)
    assert AUTONOMY_SILENT not in cells, cells
    # a robot that refuses Moves is owed no StopMove: the planner's Moves just end; the e-stop while it is silent
    refused = [(1.0, _drive_mode()), (9.02, _drive_mode(driver="autonomy")),
               (19.9, _drive_mode(driver="autonomy", suspended=silent))]
    cells = drive_cells(_planner(19.0, 10), refused, log, t_estop=20.0)
    assert AUTONOMY_SILENT in cells and ESTOP_WHILE_AUTONOMY not in cells, cells
    # the autonomy driving when a set_mode leaves HIGH_LEVEL, then a take-over that took the robot, no e-stop cell
    modes += [(19.8, _drive_mode(transition=True, target=IDLE, driver="autonomy")), (19.9, _drive_mode(IDLE, "nobody"))]
    log.take_overs.append(Call(19.6, 19.61, True, "the teleop drives; the autonomy needs a new hand-over"))
    events.append(_move(19.7, (0.0, 0.0, 0.0))[0])
    cells = drive_cells(sorted(events, key=lambda e: e["t"]), modes, log, t_estop=20.0)
    assert TAKE_OVER_SERVICE in cells and LEFT_WHILE_AUTONOMY in cells and ESTOP_WHILE_AUTONOMY not in cells, cells
