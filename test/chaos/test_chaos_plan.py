"""The chaos batch's design, without a sim: every cell aimed at, the coverage report, the judge of restarts."""

from __future__ import annotations

from types import SimpleNamespace

from chaos import policy as chaos_policy
from chaos.coverage import DRIVE_REQUIRED, POLICY_ROWS, REQUIRED, Coverage, Landing
from chaos.drivers import AUTONOMY_LIMITS, PLANNER, source_of
from chaos.plan import FIRMWARES, PATHS, SCRIPTS, SETUP, TRANSITION_DELAY_S, USER_STREAM, plan
from chaos.scenario import Claims, judge
from g1_mode_manager.protocol import api_ids
from support.holosoma import POLICY_KP_MAX


def test_any_run_of_consecutive_seeds_as_long_as_the_cell_list_aims_at_every_cell() -> None:
    for first in (0, 7000, 52017):
        assert {plan(s).aim for s in range(first, first + len(REQUIRED))} == set(REQUIRED)


def test_any_run_of_twice_as_many_seeds_aims_at_every_cell_on_each_path() -> None:
    for first in (0, 7000, 52017):
        plans = [plan(s) for s in range(first, first + 2 * len(REQUIRED))]
        assert {(p.aim, p.path) for p in plans} == {(cell, path) for cell in REQUIRED for path in PATHS}
    assert {plan(s, paths=("user_ctrl",)).path for s in range(10)} == {"user_ctrl"}


def test_the_user_ctrl_path_plays_a_firmware_and_keeps_the_switches_long_where_it_aims_at_them() -> None:
    into, out = str(api_ids.LOCO_SWITCH_TO_USER_CTRL), str(api_ids.LOCO_SWITCH_TO_INTERNAL_CTRL)
    exits = set()
    for seed in range(1, 600, 2):
        p = plan(seed)
        assert p.path == "user_ctrl" and p.faults["user_ctrl"] in FIRMWARES
        assert p.node_params[0] == "low_level_path:=user_ctrl"
        setup = [(kind, arg) for _, who, kind, arg in p.actions if who == SETUP]
        streamed = [arg for _, who, kind, arg in p.actions if who == USER_STREAM and kind == "lowcmd"]
        if p.aim[0] == "->LOW_LEVEL":
            assert setup[-1] in (("mode", "low_level"), ("policy", "engage"))
            assert p.faults["delay_s"][into][0] >= TRANSITION_DELAY_S[0]
        if p.aim == ("LOW_LEVEL", "policy"):  # held by the policy's own frames
            assert setup[-1] == ("policy", "engage") and not streamed
        elif p.aim[0] == "LOW_LEVEL":  # held by a stream, or by damping on silence where nothing may be in flight
            assert streamed or (p.aim[1] == "nothing" and "user_ctrl_silence:=damp" in p.node_params)
        if setup[:1] == [("mode", "low_level")] and len(setup) == 3:  # a way out of LOW_LEVEL after a pause
            assert setup[1][0] == "pause" and streamed and p.gantry
            assert p.faults["delay_s"][out][0] >= TRANSITION_DELAY_S[0]
            exits.add(setup[2])
    assert exits == {("mode", "high_level"), ("mode", "idle")}
    release = [plan(s) for s in range(0, 100, 2)]
    assert all(p.node_params == ("low_level_path:=release",) for p in release)
    assert not any(into in p.faults["delay_s"] or "user_ctrl" in p.faults for p in release)


def test_a_plan_is_its_seed() -> None:
    assert plan(123) == plan(123)
    assert plan(123) != plan(124)


def test_aims_set_up_what_they_aim_at() -> None:
    for seed in range(300):
        p = plan(seed)
        row, column = p.aim
        setup = [(kind, arg) for _, who, kind, arg in p.actions if who == SETUP]
        if column == "policy":  # the row's mode (HIGH_LEVEL to engage from), a walking policy loaded and shadowed
            assert setup[0] == ("mode", "idle" if row == "IDLE" else "high_level")
            verbs = [arg.partition(":")[0] for kind, arg in setup if kind == "policy"]
            assert verbs == ["disengage", "load", "shadow", *(["engage"] if "LOW_LEVEL" in row else [])]
            if row == "HIGH_LEVEL":
                assert p.script in SCRIPTS
            continue
        if row == "UNINITIALIZED":  # nothing may connect the node before the e-stop
            assert p.actions == [] and p.kill_at is None
        if row in ("IDLE", "LOW_LEVEL"):
            assert setup == [("mode", row.lower())]
        if row == "HIGH_LEVEL":  # then its script, which hands the planner the robot (the robot walking, or not)
            assert setup[0] == ("mode", "high_level") and p.script in SCRIPTS
            assert setup[1] == ("hand_over", "") or setup[1:3] == [("loco", "start"), ("hand_over", "")]
        if row == "->LOW_LEVEL" and p.path == "release":  # kept long by the robot: ReleaseMode and CheckMode late
            assert setup[-1] == ("mode", "low_level")
            for api in (api_ids.MS_RELEASE_MODE, api_ids.MS_CHECK_MODE):
                assert p.faults["delay_s"][str(api)][0] >= TRANSITION_DELAY_S[0]
        if p.kill_at is not None:
            assert 0.0 < p.kill_at <= p.setup_at


def test_every_window_of_a_hundred_seeds_plays_each_script_where_it_aims_at_high_level() -> None:
    for first in (0, 7000, 34000, 52017):
        plans = [plan(s) for s in range(first, first + 100)]
        scripts = [p.script for p in plans if p.aim[0] == "HIGH_LEVEL"]
        assert all(scripts.count(script) >= 2 for script in SCRIPTS), scripts


def test_the_planner_has_its_own_shape_and_asks_past_each_of_the_autonomys_limits() -> None:
    plans = [plan(s) for s in range(300)]
    assert all(source_of(list(p.planner_command)) == PLANNER for p in plans)
    limits = (AUTONOMY_LIMITS.max_vx, AUTONOMY_LIMITS.max_vy, AUTONOMY_LIMITS.max_wz)
    for axis, limit in enumerate(limits):
        assert any(abs(p.planner_command[axis]) > limit for p in plans)


def test_who_drives_is_in_the_noise_and_in_setups_that_leave_high_level() -> None:
    plans = [plan(s, ("medium",)) for s in range(200)]
    kinds = {kind for p in plans for _, _, kind, _ in p.actions}
    assert {"hand_over", "take_over", "planner", "drive"} <= kinds
    assert {p.script for p in plans if p.aim[0] in ("->IDLE", "->LOW_LEVEL", "FAULT")} == {"leave", None}
    assert {p.race for p in plans} == {"hand_over", "take_over", None}


def test_lengths_reach_thirty_seconds_and_forty_actions() -> None:
    plans = [plan(s) for s in range(400)]
    long = [p for p in plans if p.length == "long"]
    assert long and max(len(p.actions) for p in long) >= 35 and max(p.setup_at for p in long) > 20.0
    assert {p.length for p in plans} == {"short", "medium", "long"}
    assert all(plan(s, ("short",)).length == "short" for s in range(50))


def test_coverage_reports_missing_cells_and_e_stops_before_the_first_connect() -> None:
    cov = Coverage()
    for row, column in REQUIRED[:-1]:
        cov.add(Landing(row, (column,), connected=row != "UNINITIALIZED"), ["short scenarios"])
    assert cov.missing() == [REQUIRED[-1]]
    assert any("cells never hit" in why for why in cov.shortfalls())
    cov.add(Landing(*REQUIRED[-1][:1], (REQUIRED[-1][1],), connected=True), DRIVE_REQUIRED[:-1])
    assert cov.missing() == [] and cov.after_connect() > 0.7
    assert cov.shortfalls() == [f"drive cells never hit: {[DRIVE_REQUIRED[-1]]}"]
    cov.add(Landing("HIGH_LEVEL", ("nothing",), connected=True), DRIVE_REQUIRED[-1:])
    assert cov.shortfalls() == []
    for _ in range(100):
        cov.add(Landing("UNINITIALIZED", ("nothing",), connected=False))
    assert any("after the first connect" in why for why in cov.shortfalls())
    table = cov.table()
    assert "n/a" in table.splitlines()[7] and f"{len(REQUIRED)} of {len(REQUIRED)} cells hit" in table


def _mode(value: int, name: str, *, t: float) -> tuple[float, SimpleNamespace]:
    return t, SimpleNamespace(mode=value, name=name, damp_confirmed=False, holds=[], transition_in_progress=False)


def _damped_robot(t: float) -> dict:
    return {"k": "state", "t": t, "fsm": 1, "svc": "ai", "fsm_mode": 0}


def _move(t: float) -> dict:
    return {"k": "req", "t": t, "svc": "sport", "api": api_ids.LOCO_SET_VELOCITY,
            "p": '{"velocity": [0.3, 0.0, 0.0], "duration": 1.0}', "noreply": False}


def _judged(events: list[dict], restarts: list[tuple[float, float]], modes: list) -> list[str]:
    claims = Claims(t_estop=9.0, restarts=restarts, modes=modes)
    damp = {"k": "req", "t": 9.001, "svc": "sport", "api": 7101, "p": '{"data": 1}', "noreply": False}
    end = {"sport": {"fsm_id": 1, "mode": "ai"}}
    return judge([*events, damp, damp | {"t": 9.002}, _damped_robot(9.1)], claims, end)


def test_the_judge_sees_motion_from_a_restarted_node_before_it_was_asked_for_a_mode() -> None:
    killed = [(5.0, 8.0)]  # killed at 5 s, the fresh node asked for a mode at 8 s
    assert _judged([_move(4.9), _move(8.5)], killed, []) == []
    bad = _judged([_move(6.0)], killed, [])
    assert bad and "after the node was killed" in bad[0]


def test_a_fault_cut_short_by_a_kill_is_not_a_fault_left_to_uninitialized() -> None:
    modes = [_mode(5, "FAULT", t=2.0), _mode(0, "UNINITIALIZED", t=5.5), _mode(4, "EMERGENCY", t=9.0)]
    assert _judged([], [(5.0, 8.0)], modes) == []
    assert any("FAULT left to UNINITIALIZED" in why for why in _judged([], [], modes))


def test_a_killed_nodes_fault_claim_that_arrives_after_the_kill_is_judged_in_its_own_life() -> None:
    # the killed node's FAULT, published before it died, received 3 ms after the kill; then its successor
    modes = [_mode(5, "FAULT", t=2.0), _mode(5, "FAULT", t=5.003), _mode(0, "UNINITIALIZED", t=6.5),
             _mode(4, "EMERGENCY", t=9.0)]
    assert _judged([], [(5.0, 8.0)], modes) == []
    # a node that claims FAULT and then UNINITIALIZED in its own life is still flagged
    own_life = [_mode(5, "FAULT", t=2.0), _mode(0, "UNINITIALIZED", t=2.5), _mode(4, "EMERGENCY", t=9.0)]
    assert any("FAULT left to UNINITIALIZED" in why for why in _judged([], [(5.0, 8.0)], own_life))


def test_a_policy_is_aimed_at_where_it_can_be_at_work_and_called_in_the_noise() -> None:
    assert {cell for cell in REQUIRED if cell[1] == "policy"} == {(row, "policy") for row in POLICY_ROWS}
    assert len(REQUIRED) % 2 == 1  # else a cell's path would be fixed by its index
    plans = [plan(s, ("medium",)) for s in range(200)]
    verbs = {arg.partition(":")[0] for p in plans for _, who, kind, arg in p.actions if kind == "policy" and who != SETUP}
    assert verbs == {"load", "shadow", "engage", "disengage", "hold", "unload"}


def test_the_judge_sees_a_frame_of_the_policys_stiffness_before_any_engage() -> None:
    frame = {"k": "frame", "topic": "user_lowcmd", "t": 3.0, "kp_max": POLICY_KP_MAX, "why": "", "ok": True}
    assert chaos_policy.judge([frame], engages=[2.5]) == []
    bad = chaos_policy.judge([frame], engages=[3.5])
    assert bad and "before any engage" in bad[0]
    assert chaos_policy.judge([frame | {"kp_max": 40.0}], engages=[]) == []


def test_a_policy_counts_as_at_work_from_its_shadow_on_in_the_node_that_gets_the_e_stop() -> None:
    statuses = [(1.0, "loaded", ""), (2.0, "shadow", ""), (3.0, "running", "")]
    assert chaos_policy.at_work(statuses, since=0.0)
    assert not chaos_policy.at_work(statuses[:1], since=0.0)
    assert not chaos_policy.at_work(statuses, since=3.5)  # a killed node's status says nothing of its successor
    assert not chaos_policy.at_work([*statuses, (4.0, "loaded", "the policy failed")], since=0.0)
