"""The mode machine against a fake robot: every table cell, the failure paths, records, and e-stop preemption."""

from __future__ import annotations

import threading
import time

import pytest

from fakes.fake_robot import ACTIVE, RELEASED, Call
from fakes.machine_rig import make_rig
from g1_mode_manager.core import modes
from g1_mode_manager.core.estop_policy import EstopTiming
from g1_mode_manager.core.machine import Outcome, Result
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.protocol import api_ids

UN, ID, HI, LO, EM = Mode.UNINITIALIZED, Mode.IDLE, Mode.HIGH_LEVEL, Mode.LOW_LEVEL, Mode.EMERGENCY
#: An e-stop that gives up quickly, for the failure paths (the default retries for 10 s).
FAST_FAIL = EstopTiming(select_s=0.2, total_s=0.2)

#: Robot calls of each legal cell, starting from a robot whose high-level service is active and a
#: machine that reached the source mode the ordinary way.
EXPECTED_CALLS: dict[tuple[Mode, Mode], list[str]] = {
    (UN, ID): ["connect"],
    (UN, HI): ["connect", "check_mode"],
    (UN, LO): ["connect", "check_mode", "release_mode", "check_mode"],
    (ID, HI): ["check_mode"],
    (ID, LO): ["check_mode", "release_mode", "check_mode"],
    (HI, ID): [],
    (HI, LO): ["check_mode", "release_mode", "check_mode"],
    (LO, ID): [],
    (LO, HI): ["check_mode", "select_mode", "check_mode"],
    # e-stop: DampNoReply first, service active, Damp, then verified on the robot (CheckMode + GetFsmId)
    (UN, EM): ["connect", "damp_no_reply", "check_mode", "damp", "check_mode", "get_fsm_id"],
    (ID, EM): ["damp_no_reply", "check_mode", "damp", "check_mode", "get_fsm_id"],
    (HI, EM): ["damp_no_reply", "check_mode", "damp", "check_mode", "get_fsm_id"],
    # from LOW_LEVEL a DampNoReply the moment SelectMode answers, before its confirmation: the robot is limp then
    (LO, EM): ["damp_no_reply", "check_mode", "select_mode", "damp_no_reply", "check_mode", "damp", "check_mode",
               "get_fsm_id"],
    (EM, EM): ["damp_no_reply", "check_mode", "damp", "check_mode", "get_fsm_id"],
}
REFUSALS: dict[tuple[Mode, Mode], str] = {
    **{(EM, m): "nothing leaves EMERGENCY" for m in (UN, ID, HI, LO)},
    **{(m, UN): "nothing goes back to UNINITIALIZED" for m in (ID, HI, LO)},
    **{(m, m): f"already in {m.name}" for m in (UN, ID, HI, LO)},
}


def _ids(pair: tuple[Mode, Mode]) -> str:
    return f"{pair[0].name}->{pair[1].name}"


def damps_while_active(calls: list[Call]) -> list[Call]:
    return [c for c in calls if c.name == "damp" and c.ok and c.service]


# --- the table, cell by cell ---------------------------------------------------------------------------
@pytest.mark.parametrize("pair", list(EXPECTED_CALLS), ids=_ids)
def test_legal_cell_succeeds_with_the_expected_robot_calls(pair: tuple[Mode, Mode]) -> None:
    source, target = pair
    rig = make_rig()
    rig.bring_to(source)
    before, records_before = len(rig.robot.calls), len(rig.records)

    outcome = rig.machine.request(target)

    assert outcome.success and not outcome.refused, outcome
    assert outcome.mode is target and rig.machine.mode is target
    assert rig.robot.names(before) == EXPECTED_CALLS[pair]
    assert [(r.source, r.target, r.outcome) for r in rig.records[records_before:]] == [(source, target, Result.OK)]
    assert not rig.machine.status().transition_in_progress
    if target is EM:
        assert damps_while_active(rig.robot.calls[before:])
        assert rig.machine.status().damp_confirmed and rig.robot.damped


@pytest.mark.parametrize("pair", list(REFUSALS), ids=_ids)
def test_illegal_cell_is_refused_with_its_reason_and_no_robot_call(pair: tuple[Mode, Mode]) -> None:
    source, target = pair
    rig = make_rig()
    rig.bring_to(source)
    before = len(rig.robot.calls)

    outcome = rig.machine.request(target)

    assert outcome.refused and not outcome.success
    assert REFUSALS[pair] in outcome.message
    assert outcome.mode is source and rig.machine.mode is source
    assert rig.robot.names(before) == []
    assert rig.records[-1].outcome is Result.REFUSED
    assert (rig.records[-1].source, rig.records[-1].target) == pair
    assert rig.machine.status().last_refusal == outcome.message


def test_table_cells_cover_all_25_pairs() -> None:
    assert len(EXPECTED_CALLS) + len(REFUSALS) == 25


@pytest.mark.parametrize("mode", [ID, HI, LO], ids=lambda m: m.name)
def test_repeated_requests_are_refused_after_the_first(mode: Mode) -> None:
    rig = make_rig()
    outcomes = [rig.machine.request(mode) for _ in range(3)]
    assert [o.success for o in outcomes] == [True, False, False]
    assert [o.refused for o in outcomes] == [False, True, True]
    assert rig.machine.mode is mode
    assert rig.robot.names().count("connect") == 1


def test_repeated_estops_each_run_the_whole_sequence() -> None:
    rig = make_rig()
    outcomes = [rig.machine.estop() for _ in range(3)]
    assert all(o.success and o.mode is EM for o in outcomes)
    assert rig.robot.names().count("damp") == 3
    assert rig.robot.names().count("damp_no_reply") == 3


def test_request_emergency_is_an_estop() -> None:
    rig = make_rig()
    rig.bring_to(HI)
    outcome = rig.machine.request(EM)
    assert outcome.success and rig.machine.is_emergency()
    assert "robot damped (verified" in outcome.message


def test_request_accepts_message_numbers_and_rejects_unknown_ones() -> None:
    rig = make_rig()
    assert rig.machine.request(2).success and rig.machine.mode is HI  # type: ignore[arg-type]
    assert rig.machine.request(4).success and rig.machine.is_emergency()  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown mode number 9"):
        rig.machine.request(9)  # type: ignore[arg-type]


# --- service handling ---------------------------------------------------------------------------------
def test_high_level_from_released_robot_selects_and_reports_zero_torque() -> None:
    rig = make_rig(service=RELEASED)
    outcome = rig.machine.request(HI)
    assert outcome.success
    assert rig.robot.names() == ["connect", "check_mode", "select_mode", "check_mode"]
    assert rig.robot.calls[2].args == (api_ids.HIGH_LEVEL_SERVICE_NAME,)
    assert "zero torque; send stand_up/damp" in outcome.message
    assert rig.robot.service == ACTIVE


def test_high_level_from_low_level_reports_zero_torque() -> None:
    rig = make_rig()
    rig.bring_to(LO)
    outcome = rig.machine.request(HI)
    assert "robot is in zero torque; send stand_up/damp" in outcome.message


def test_high_level_with_service_already_active_does_not_select() -> None:
    rig = make_rig()
    outcome = rig.machine.request(HI)
    assert "select_mode" not in rig.robot.names()
    assert "zero torque" not in outcome.message


def test_select_confirmation_polls_a_lagging_check_mode() -> None:
    rig = make_rig(service=RELEASED)
    rig.robot.lag_check(3)
    outcome = rig.machine.request(HI)
    assert outcome.success
    assert rig.robot.names().count("check_mode") == 1 + 4
    assert rig.robot.names().count("select_mode") == 1


def test_select_never_confirmed_times_out_and_keeps_the_old_mode() -> None:
    rig = make_rig(service=RELEASED, select_timeout_s=2.0, poll_interval_s=0.1)
    rig.bring_to(ID)
    rig.robot.select_never_works = True
    outcome = rig.machine.request(HI)
    assert not outcome.success and not outcome.refused
    assert rig.machine.mode is ID
    assert "still not active 2 s after SelectMode('ai')" in outcome.message
    assert rig.robot.names().count("select_mode") == 1
    assert 18 <= rig.robot.names().count("check_mode") <= 24  # bounded polling, ~2 s / 0.1 s
    assert rig.clock is not None and rig.clock.slept == pytest.approx(2.0, abs=0.15)
    status = rig.machine.status()
    assert status.last_refusal == outcome.message and "still not active" in status.last_error
    assert not status.service_known or not status.service_active


def test_low_level_needing_several_releases() -> None:
    rig = make_rig()
    rig.robot.release_attempts = 3
    rig.bring_to(HI)
    outcome = rig.machine.request(LO)
    assert outcome.success
    assert rig.robot.names().count("release_mode") == 3
    assert rig.robot.service == RELEASED
    status = rig.machine.status()
    assert status.service_known and not status.service_active


def test_low_level_release_never_taking_effect_times_out_and_keeps_high_level() -> None:
    rig = make_rig(release_timeout_s=1.5, poll_interval_s=0.1)
    rig.bring_to(HI)
    rig.robot.release_never_works = True
    outcome = rig.machine.request(LO)
    assert not outcome.success and rig.machine.mode is HI
    assert "high-level service still active after 1.5 s" in outcome.message
    assert 14 <= rig.robot.names().count("release_mode") <= 17
    assert rig.records[-1].outcome is Result.FAILED


def test_low_level_stale_check_mode_keeps_releasing_until_it_reports_released() -> None:
    rig = make_rig()
    rig.bring_to(ID)
    rig.robot.lag_check(2)
    assert rig.machine.request(LO).success
    assert rig.robot.names().count("release_mode") == 3


def test_check_mode_lying_released_makes_high_level_select_again() -> None:
    rig = make_rig()
    rig.bring_to(ID)
    rig.robot.lie_check(1)
    outcome = rig.machine.request(HI)
    assert outcome.success and rig.robot.service == ACTIVE
    assert rig.robot.names()[-3:] == ["check_mode", "select_mode", "check_mode"]


# --- failures keep the old mode -------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("source", "target", "call"),
    [
        (UN, ID, "connect"),
        (UN, HI, "connect"),
        (UN, LO, "connect"),
        (UN, HI, "check_mode"),
        (ID, HI, "check_mode"),
        (LO, HI, "select_mode"),
        (LO, HI, "check_mode"),
        (ID, LO, "release_mode"),
        (HI, LO, "check_mode"),
        (HI, LO, "release_mode"),
    ],
    ids=lambda x: x.name if isinstance(x, Mode) else x,
)
@pytest.mark.parametrize("code", [api_ids.ERR_CLIENT_API_TIMEOUT, api_ids.ERR_CLIENT_SEND])
def test_robot_error_keeps_the_old_mode_and_says_why(source: Mode, target: Mode, call: str, code: int) -> None:
    rig = make_rig()
    rig.bring_to(source)
    rig.robot.fail(call, code)
    outcome = rig.machine.request(target)
    assert not outcome.success and not outcome.refused
    assert outcome.mode is source and rig.machine.mode is source
    assert f"{call} failed: {code}" in outcome.message
    assert f"staying in {source.name}" in outcome.message
    status = rig.machine.status()
    assert not status.transition_in_progress
    assert f"{call} failed" in status.last_error
    # nothing is half done: the same request works once the fault is gone
    assert rig.machine.request(target).success


@pytest.mark.parametrize("exc", [RuntimeError("boom"), ValueError("bad json"), TimeoutError()])
def test_unexpected_exception_from_the_port_is_reported_not_raised(exc: Exception) -> None:
    rig = make_rig(service=RELEASED)
    rig.bring_to(ID)
    rig.robot.crash("select_mode", exc)
    outcome = rig.machine.request(HI)
    assert not outcome.success and rig.machine.mode is ID
    assert type(exc).__name__ in outcome.message
    assert not rig.machine.status().transition_in_progress


def test_connect_failure_stays_uninitialized_and_is_retried() -> None:
    rig = make_rig()
    rig.robot.fail("connect", api_ids.ERR_CLIENT_SEND)
    outcome = rig.machine.request(HI)
    assert not outcome.success and rig.machine.mode is UN
    assert "connect failed" in outcome.message
    assert rig.machine.request(HI).success
    assert rig.robot.names().count("connect") == 2


# --- e-stop failure paths ----------------------------------------------------------------------------
def test_a_damp_failure_is_retried_within_the_same_estop() -> None:
    rig = make_rig()
    rig.bring_to(LO)
    rig.robot.fail("damp", api_ids.ERR_CLIENT_API_TIMEOUT)
    outcome = rig.machine.estop()
    assert outcome.success and outcome.mode is EM, outcome
    assert "retrying: damp failed: 3104" in outcome.message
    assert rig.robot.names().count("damp") == 2
    assert rig.machine.status().damp_confirmed and rig.robot.damped


def test_damp_failing_for_the_whole_budget_fails_then_a_repeat_succeeds() -> None:
    rig = make_rig(estop_timing=FAST_FAIL)
    rig.bring_to(LO)
    rig.robot.fail("damp", api_ids.ERR_CLIENT_API_TIMEOUT, times=1000)
    first = rig.machine.estop()
    assert not first.success and first.mode is EM and rig.machine.is_emergency()
    assert first.message.startswith("e-stop incomplete: damp failed: 3104")
    assert "supervision keeps trying" in first.message
    assert not rig.machine.status().damp_confirmed
    assert rig.records[-1].outcome is Result.FAILED

    rig.robot.clear_faults()
    second = rig.machine.estop()
    assert second.success and rig.machine.is_emergency()
    assert rig.machine.status().damp_confirmed and rig.robot.damped


def test_estop_from_high_level_reselects_a_service_released_behind_its_back() -> None:
    rig = make_rig()
    rig.bring_to(HI)
    rig.robot.set_service(RELEASED)  # released behind the machine's back: Damp cannot work yet
    before = len(rig.robot.calls)
    outcome = rig.machine.estop()
    assert outcome.success, outcome
    assert rig.robot.names(before) == ["damp_no_reply", "check_mode", "select_mode", "damp_no_reply", "check_mode",
                                       "damp", "check_mode", "get_fsm_id"]
    assert rig.robot.damped and rig.robot.service == ACTIVE


def test_estop_success_needs_the_robot_to_show_damping() -> None:
    """A Damp the robot acknowledges but does not execute is no success: verified by GetFsmId."""
    rig = make_rig(estop_timing=FAST_FAIL)
    rig.bring_to(HI)
    original = rig.robot.damp

    def acknowledged_but_ignored(timeout_s: float | None = None) -> None:
        original(timeout_s)
        rig.robot.undamp()

    rig.robot.damp = acknowledged_but_ignored  # type: ignore[method-assign]
    rig.robot.damp_no_reply = lambda: None  # type: ignore[method-assign]
    outcome = rig.machine.estop()
    assert not outcome.success and "robot not damping: GetFsmId says 4" in outcome.message
    assert not rig.machine.status().damp_confirmed


@pytest.mark.parametrize("source", [UN, ID, LO, EM], ids=lambda m: m.name)
def test_estop_when_service_cannot_be_made_active(source: Mode) -> None:
    rig = make_rig(service=RELEASED, estop_timing=EstopTiming(select_s=1.0, total_s=1.0))
    rig.bring_to(source)
    rig.robot.set_service(RELEASED)
    rig.robot.select_never_works = True
    before = len(rig.robot.calls)
    outcome = rig.machine.estop()
    assert not outcome.success and rig.machine.is_emergency()
    assert "e-stop incomplete: high-level service still not active 1 s" in outcome.message
    assert "damp" not in rig.robot.names(before)
    rig.robot.select_never_works = False
    assert rig.machine.estop().success
    assert damps_while_active(rig.robot.calls[before:])


def test_estop_select_error_is_reported() -> None:
    rig = make_rig(service=RELEASED, estop_timing=FAST_FAIL)
    rig.bring_to(LO)
    rig.robot.fail("select_mode", api_ids.ERR_CLIENT_API_TIMEOUT, times=1000)
    outcome = rig.machine.estop()
    assert not outcome.success and "select_mode failed: 3104" in outcome.message
    assert rig.machine.status().last_error.startswith("select_mode failed")


def test_estop_from_uninitialized_connects_first_and_retries_a_failed_connect() -> None:
    rig = make_rig()
    rig.robot.fail("connect", api_ids.ERR_CLIENT_SEND)
    outcome = rig.machine.estop()
    assert outcome.success and rig.machine.is_emergency()
    assert "retrying: connect failed" in outcome.message
    assert rig.robot.names()[:3] == ["connect", "connect", "damp_no_reply"]


def test_estop_reports_a_connect_that_never_works() -> None:
    rig = make_rig(estop_timing=FAST_FAIL)
    rig.robot.fail("connect", api_ids.ERR_CLIENT_SEND, times=1000)
    outcome = rig.machine.estop()
    assert not outcome.success and rig.machine.is_emergency()
    assert "connect failed" in outcome.message


def test_damp_no_reply_failure_does_not_stop_the_estop() -> None:
    rig = make_rig()
    rig.bring_to(ID)
    rig.robot.fail("damp_no_reply", api_ids.ERR_CLIENT_SEND)
    outcome = rig.machine.estop()
    assert outcome.success
    assert "DampNoReply failed" in outcome.message


@pytest.mark.parametrize("call", ["damp", "check_mode", "damp_no_reply", "get_fsm_id"])
def test_estop_survives_unexpected_exceptions(call: str) -> None:
    rig = make_rig()
    rig.bring_to(ID)
    rig.robot.crash(call, RuntimeError("driver bug"))
    outcome = rig.machine.estop()
    assert rig.machine.is_emergency() and outcome.mode is EM
    assert outcome.success and rig.robot.damped
    if call != "damp_no_reply":
        assert "RuntimeError" in outcome.message


def test_estop_with_check_mode_lying_active_fails_damp_then_reselects() -> None:
    rig = make_rig()
    rig.bring_to(LO)  # released
    rig.robot.lie_check(1)  # the next CheckMode claims the service is active
    outcome = rig.machine.estop()
    assert outcome.success and rig.robot.damped
    assert "retrying: damp failed" in outcome.message


# --- records, history, status, callbacks ------------------------------------------------------------
def test_every_attempt_is_recorded_once() -> None:
    rig = make_rig(history_size=4)
    attempts = [HI, HI, LO, UN, ID, EM, ID]
    for target in attempts:
        rig.machine.request(target)
    assert len(rig.records) == len(attempts)
    assert [r.target for r in rig.records] == attempts
    assert [r.outcome for r in rig.records] == [
        Result.OK,
        Result.REFUSED,
        Result.OK,
        Result.REFUSED,
        Result.OK,
        Result.OK,
        Result.REFUSED,
    ]
    assert rig.machine.history == tuple(rig.records[-4:])
    assert all(r.duration_s >= 0 for r in rig.records)


def test_on_change_reports_transition_start_and_end() -> None:
    rig = make_rig()
    rig.machine.request(HI)
    starts = [s for s in rig.statuses if s.transition_in_progress]
    assert [(s.mode, s.transition_target) for s in starts] == [(UN, HI)]
    assert rig.statuses[-1].mode is HI and not rig.statuses[-1].transition_in_progress
    assert rig.statuses[-1] == rig.machine.status()


def test_estop_notifies_the_mode_switch_before_its_result() -> None:
    rig = make_rig()
    rig.bring_to(LO)
    seen = len(rig.statuses)
    rig.robot.fail("damp")
    rig.machine.estop()
    first, last = rig.statuses[seen], rig.statuses[-1]
    assert first.mode is EM and not first.damp_confirmed
    assert last.mode is EM and last.damp_confirmed
    assert all(s.mode is EM for s in rig.statuses[seen:])


def test_status_service_knowledge_follows_check_mode() -> None:
    rig = make_rig()
    assert not rig.machine.status().service_known
    rig.bring_to(ID)
    assert not rig.machine.status().service_known  # connect alone learns nothing
    rig.bring_to(HI)
    assert rig.machine.status().service_known and rig.machine.status().service_active
    rig.bring_to(LO)
    assert rig.machine.status().service_known and not rig.machine.status().service_active


def test_a_raising_callback_never_breaks_the_estop() -> None:
    def explode(_: object) -> None:
        raise RuntimeError("node bug")

    rig = make_rig(on_change=explode, on_record=explode)
    rig.bring_to(LO)
    outcome = rig.machine.estop()
    assert outcome.success and rig.machine.is_emergency()
    assert "callback raised RuntimeError" in rig.machine.status().last_error


@pytest.mark.parametrize("mode", list(Mode), ids=lambda m: m.name)
def test_predicates_follow_the_mode(mode: Mode) -> None:
    rig = make_rig()
    rig.bring_to(mode)
    m = rig.machine
    assert m.allows_cmd_vel() == modes.allows_cmd_vel(mode)
    assert m.allows_arm_commands() == modes.allows_arm_commands(mode)
    assert m.allows_loco_commands() == modes.allows_loco_commands(mode)
    assert m.allows_low_level_commands() == modes.allows_low_level_commands(mode)
    assert m.is_emergency() == (mode is EM)


@pytest.mark.parametrize(("source", "target"), [(HI, LO), (LO, HI), (HI, ID)], ids=lambda m: m.name)
def test_predicates_allow_nothing_while_a_transition_runs(source: Mode, target: Mode) -> None:
    seen: list[tuple[bool, ...]] = []
    probing: list[bool] = []

    def probe(status: object) -> None:
        m = rig.machine
        if probing and m.status().transition_in_progress:
            seen.append((m.allows_cmd_vel(), m.allows_arm_commands(), m.allows_loco_commands(), m.allows_low_level_commands()))

    rig = make_rig(on_change=probe)
    rig.bring_to(source)
    probing.append(True)
    assert rig.machine.request(target).success
    assert seen == [(False, False, False, False)]


# --- threads: busy refusal and e-stop preemption --------------------------------------------------------
def _in_thread(fn, *args) -> tuple[threading.Thread, list[Outcome]]:  # type: ignore[no-untyped-def]
    out: list[Outcome] = []
    thread = threading.Thread(target=lambda: out.append(fn(*args)), name=f"t-{fn.__name__}", daemon=True)
    thread.start()
    return thread, out


def test_concurrent_request_is_refused_busy_not_queued() -> None:
    rig = make_rig(service=RELEASED, real_time=True)
    rig.bring_to(ID)
    hold = rig.robot.hold("select_mode")
    thread, out = _in_thread(rig.machine.request, HI)
    assert hold.wait_entered()
    before = len(rig.robot.calls)

    busy = rig.machine.request(LO)

    assert busy.refused and busy.message == "busy: transition IDLE->HIGH_LEVEL in progress"
    assert busy.mode is ID
    assert rig.robot.names(before) == []
    status = rig.machine.status()
    assert status.transition_in_progress and status.transition_target is HI
    hold.release()
    thread.join(5)
    assert out and out[0].success and rig.machine.mode is HI


def test_estop_waits_for_a_select_in_flight_before_it_claims_success() -> None:
    rig = make_rig(service=RELEASED, real_time=True, poll_interval_s=0.01)
    rig.bring_to(ID)
    hold = rig.robot.hold("select_mode")
    transition, t_out = _in_thread(rig.machine.request, HI)
    assert hold.wait_entered()
    before = len(rig.robot.calls)

    estop, e_out = _in_thread(rig.machine.estop)
    estop.join(0.5)

    # the robot is damped already, but the transition's SelectMode has not landed: no answer yet
    assert estop.is_alive() and transition.is_alive()
    assert rig.machine.is_emergency() and not rig.machine.status().damp_confirmed
    estop_calls = rig.robot.calls[before:]
    assert estop_calls[0].name == "damp_no_reply"
    assert all(c.thread == estop.name for c in estop_calls)
    assert damps_while_active(estop_calls)
    assert not rig.machine.status().transition_in_progress
    assert not rig.machine.allows_cmd_vel()

    hold.release()
    transition.join(5)
    estop.join(5)
    assert not transition.is_alive() and not estop.is_alive()
    assert [c for c in rig.robot.calls[before:] if c.thread == transition.name and c.name != "select_mode"] == [], \
        "the preempted transition touched the robot again"
    assert e_out[0].success and e_out[0].mode is EM, e_out[0]
    assert "preempted IDLE->HIGH_LEVEL" in e_out[0].message
    assert not t_out[0].success and t_out[0].mode is EM
    assert [(r.source, r.target) for r in rig.records if r.outcome is Result.PREEMPTED] == [(ID, HI)]
    assert rig.robot.damped and rig.machine.status().damp_confirmed


def test_a_release_landing_after_the_estop_damp_is_followed_by_reselect_and_damp() -> None:
    """The race of a real robot: ReleaseMode takes seconds and lands after the e-stop's Damp."""
    rig = make_rig(real_time=True, poll_interval_s=0.005, release_timeout_s=10.0)
    rig.bring_to(HI)
    hold = rig.robot.hold("release_mode")  # the transition's ReleaseMode is slow inside the robot
    transition, t_out = _in_thread(rig.machine.request, LO)
    assert hold.wait_entered()

    estop, e_out = _in_thread(rig.machine.estop)
    deadline = time.monotonic() + 5
    while not rig.robot.damped and time.monotonic() < deadline:
        time.sleep(0.001)
    assert rig.robot.damped and estop.is_alive()
    landed = len(rig.robot.calls)
    hold.release()  # ... and now it lands: the robot is released (debug mode), no longer damped
    transition.join(5)
    estop.join(5)

    assert e_out[0].success, e_out[0]
    assert rig.robot.service == ACTIVE and rig.robot.damped
    after = rig.robot.names(landed)
    assert "select_mode" in after and after.index("select_mode") < len(after) - after[::-1].index("damp") - 1
    assert t_out[0].mode is EM and rig.records[-1].outcome is Result.OK
    assert [c for c in rig.robot.calls[landed:] if c.thread == transition.name] == []


def test_estop_during_a_free_running_release_loop() -> None:
    """Without a hold: the loop may have one call already under way, never more."""
    rig = make_rig(real_time=True, poll_interval_s=0.002, release_timeout_s=10.0)
    rig.bring_to(HI)
    rig.robot.release_never_works = True
    transition, t_out = _in_thread(rig.machine.request, LO)
    deadline = time.monotonic() + 5
    while rig.robot.names().count("release_mode") < 3 and time.monotonic() < deadline:
        time.sleep(0.001)
    assert rig.robot.names().count("release_mode") >= 3

    outcome = rig.machine.estop()
    transition.join(5)

    assert outcome.success and rig.machine.is_emergency() and t_out[0].mode is EM
    calls = rig.robot.calls
    first_estop = next(i for i, c in enumerate(calls) if c.name == "damp_no_reply")
    late = [c for c in calls[first_estop:] if c.thread == transition.name]
    assert len(late) <= 1, late
    # the transition's own record (the e-stop's may be written before or after it: two threads)
    assert [r.outcome for r in rig.records if (r.source, r.target) == (HI, LO)] == [Result.PREEMPTED], rig.records


def test_a_second_estop_fires_at_once_and_joins_the_running_sequence() -> None:
    rig = make_rig(real_time=True)
    rig.bring_to(LO)
    hold = rig.robot.hold("damp")
    first, out1 = _in_thread(rig.machine.estop)
    assert hold.wait_entered()
    second, out2 = _in_thread(rig.machine.estop)
    # the second fires its own DampNoReply at once, then joins the running sequence (no queueing); the first
    # sequence fired two already (its first shot, and one at SelectMode's answer: from LOW_LEVEL)
    deadline = time.monotonic() + 5
    while rig.robot.names().count("damp_no_reply") < 3 and time.monotonic() < deadline:
        time.sleep(0.001)
    assert rig.robot.names().count("damp_no_reply") == 3
    hold.release()
    first.join(5)
    second.join(5)
    assert out1[0].success and out2[0].success
    assert rig.machine.is_emergency() and rig.robot.damped
    assert rig.robot.names().count("damp") == 1  # one sequence served both requests


def test_a_relay_send_held_past_the_forward_wait_lands_before_the_sequences_damp() -> None:
    """Registration waits only forward_wait_s for the forward gate; a send allowed before it that is still on
    its way (a descheduled relay thread) must reach the robot before the e-stop sequence's own Damp."""
    rig = make_rig(real_time=True)
    rig.bring_to(HI)
    inside, finish = threading.Event(), threading.Event()
    before_send: list[str] = []

    def relay_send() -> None:
        with rig.machine.forwarding(lambda mode: mode is HI) as decision:
            assert decision.allowed and decision.mode is HI
            inside.set()
            finish.wait(5.0)  # the relay thread stalls mid-send, past the e-stop's 50 ms wait
            before_send.extend(rig.robot.names())
            rig.robot.undamp()  # stands in for the frame the relay was sending (it moves the robot)

    relay = threading.Thread(target=relay_send)
    relay.start()
    assert inside.wait(5.0)
    estop, out = _in_thread(rig.machine.estop)
    deadline = time.monotonic() + 5
    while "damp_no_reply" not in rig.robot.names() and time.monotonic() < deadline:
        time.sleep(0.001)
    time.sleep(0.2)  # registered (without the gate) and the sequence is running
    assert rig.machine.is_emergency()
    assert "damp" not in rig.robot.names(), "the sequence's Damp went out while a relay send was still on its way"
    finish.set()
    relay.join(5)
    estop.join(5)
    assert "damp" not in before_send and "damp" in rig.robot.names()  # the Damp came after the send
    assert out[0].success and rig.robot.damped


@pytest.mark.parametrize("mode", [HI, LO])
def test_the_forward_gate_hands_over_what_it_judged_and_is_never_mistaken_for_a_bool(mode) -> None:
    rig = make_rig(service=RELEASED if mode is LO else ACTIVE)
    rig.bring_to(mode)
    with rig.machine.forwarding(modes.allows_cmd_vel) as decision:
        assert decision.allowed == (mode is HI) and decision.mode is mode
        with pytest.raises(TypeError, match="allowed"):
            bool(decision)  # `if decision:` would pass in every mode
