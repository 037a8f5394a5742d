"""FAULT and holds against the fake robot: the protective stop, its clear, and what passes meanwhile."""

from __future__ import annotations

import threading

import pytest

from fakes.fake_robot import RELEASED
from fakes.machine_rig import make_rig
from g1_mode_manager.core import modes
from g1_mode_manager.core.machine import Result
from g1_mode_manager.core.modes import Mode

ID, HI, LO, EM, FA = Mode.IDLE, Mode.HIGH_LEVEL, Mode.LOW_LEVEL, Mode.EMERGENCY, Mode.FAULT
TILT = ("tilt: 1.32 rad > 1",)
ALL_CLEAR = (lambda: "", lambda: None)


@pytest.mark.parametrize("source", [ID, HI, LO], ids=lambda m: m.name)
def test_a_fault_damps_the_robot_and_verifies_it(source: Mode) -> None:
    rig = make_rig()
    rig.bring_to(source)
    start = len(rig.robot.calls)
    assert rig.machine.fault(TILT)
    assert rig.machine.mode is FA
    assert rig.wait_damp_confirmed()
    names = rig.robot.names(start)
    assert names[0] == "damp_no_reply", names
    assert names[-2:] == ["check_mode", "get_fsm_id"], names  # verified on the robot
    assert rig.robot.damped and rig.robot.service
    status = rig.machine.status()
    assert status.faults == TILT and status.damp_confirmed
    record = next(r for r in rig.records if r.target is FA)
    assert record.outcome is Result.REGISTERED and "tilt" in record.message


def test_nothing_passes_in_fault_and_set_mode_is_refused_with_the_faults() -> None:
    rig = make_rig()
    rig.bring_to(FA)
    m = rig.machine
    assert not (m.allows_cmd_vel() or m.allows_arm_commands() or m.allows_loco_commands()
                or m.allows_low_level_commands())
    with m.forwarding(modes.allows_arm_commands) as decision:
        assert not decision.allowed and not modes.allows_arm_ramp_out(decision.mode)  # nothing but damping
    for target in (ID, HI, LO):
        outcome = m.request(target)
        assert outcome.refused and m.mode is FA
        assert "clear_fault" in outcome.message and "tilt: 1.32 rad" in outcome.message


def test_set_mode_fault_is_refused() -> None:
    rig = make_rig()
    rig.bring_to(HI)
    outcome = rig.machine.request(FA)
    assert outcome.refused and "not requested" in outcome.message and rig.machine.mode is HI


def test_clear_refused_while_a_check_is_active_then_accepted_to_idle_with_the_robot_still_damped() -> None:
    rig = make_rig()
    rig.bring_to(FA)
    released: list[bool] = []
    outcome = rig.machine.clear_fault(lambda: "tilt still active", lambda: released.append(True))
    assert outcome.refused and "tilt still active" in outcome.message and rig.machine.mode is FA
    assert released == []
    calls = len(rig.robot.calls)
    outcome = rig.machine.clear_fault(lambda: "", lambda: released.append(True))
    assert outcome.success and rig.machine.mode is ID and released == [True]
    assert rig.machine.status().faults == ()
    assert rig.robot.names(calls) == []  # nothing sent: the robot stays damped, no motion restarts
    assert rig.robot.damped


def test_clear_waits_until_the_robot_was_seen_damped() -> None:
    rig = make_rig(real_time=True)
    rig.bring_to(HI)
    hold = rig.robot.hold("damp")
    assert rig.machine.fault(TILT)
    assert hold.wait_entered()
    outcome = rig.machine.clear_fault(*ALL_CLEAR)
    assert outcome.refused and "not yet seen the robot damped" in outcome.message
    hold.release()
    assert rig.wait_damp_confirmed()
    assert rig.machine.clear_fault(*ALL_CLEAR).success and rig.machine.mode is ID


def test_leaving_fault_leaves_no_damp_confirmed_behind() -> None:
    """damp_confirmed is the stop's claim: IDLE after a clear, and the modes after it, make none (LOW_LEVEL
    releases the robot, and a client reading the flag would believe it damped)."""
    rig = make_rig()
    rig.bring_to(FA)
    assert rig.machine.status().damp_confirmed
    assert rig.machine.clear_fault(*ALL_CLEAR).success
    assert rig.machine.mode is ID and not rig.machine.status().damp_confirmed
    assert rig.machine.request(LO).success
    assert not rig.machine.status().damp_confirmed and not rig.robot.damped


def test_clear_outside_fault_without_holds_is_refused() -> None:
    rig = make_rig()
    rig.bring_to(HI)
    outcome = rig.machine.clear_fault(*ALL_CLEAR)
    assert outcome.refused and "no fault to clear" in outcome.message


def test_an_estop_overrides_fault() -> None:
    rig = make_rig()
    rig.bring_to(FA)
    outcome = rig.machine.estop()
    assert outcome.success and rig.machine.mode is EM
    assert rig.machine.clear_fault(*ALL_CLEAR).refused and rig.machine.mode is EM


@pytest.mark.parametrize("mode", [Mode.UNINITIALIZED, EM], ids=lambda m: m.name)
def test_no_fault_before_connect_or_in_emergency(mode: Mode) -> None:
    rig = make_rig()
    rig.bring_to(mode)
    assert not rig.machine.fault(TILT)
    assert rig.machine.mode is mode


def test_a_second_fault_is_added_to_the_list() -> None:
    rig = make_rig()
    rig.bring_to(FA)
    assert not rig.machine.fault(("spin: 7.00 rad/s > 6",))
    assert rig.machine.status().faults == (*TILT, "spin: 7.00 rad/s > 6")


def test_a_fault_preempts_a_running_transition() -> None:
    rig = make_rig(real_time=True)
    rig.bring_to(HI)
    hold = rig.robot.hold("release_mode")
    out: list[object] = []
    transition = threading.Thread(target=lambda: out.append(rig.machine.request(LO)), daemon=True)
    transition.start()
    assert hold.wait_entered()
    assert rig.machine.fault(TILT)
    hold.release()
    transition.join(5.0)
    assert out and out[0].mode is FA and not out[0].success  # type: ignore[attr-defined]
    assert next(r for r in rig.records if r.target is LO).outcome is Result.PREEMPTED
    assert rig.wait_damp_confirmed() and rig.machine.mode is FA


def test_supervision_in_fault_redamps_a_robot_that_left_damping() -> None:
    rig = make_rig()
    rig.bring_to(FA)
    rig.robot.undamp()
    rig.clock.advance(2.0)  # type: ignore[union-attr]
    rig.machine.supervise(fsm_id=4, state_age_s=0.05)
    assert rig.robot.damped
    assert rig.machine.status().reasserts == 1 and rig.machine.mode is FA


def test_a_hold_stops_motion_keeps_the_mode_and_lets_damp_and_ramp_out_pass() -> None:
    rig = make_rig()
    rig.bring_to(HI)
    m = rig.machine
    m.hold(("winding_overheat: 121.00 °C > 120",))
    assert m.mode is HI and m.status().holds
    assert not (m.allows_cmd_vel() or m.allows_arm_commands() or m.allows_loco_commands())
    with m.forwarding(modes.allows_cmd_vel) as decision:
        assert not decision.allowed
        assert modes.allows_arm_ramp_out(decision.mode)  # the arm weight ramps out
    with m.robot_call(modes.allows_loco_commands) as allowed:
        assert not allowed
    with m.robot_call(lambda mode: mode is HI, stopping=True) as allowed:
        assert allowed  # damp
    assert m.clear_fault(lambda: "winding_overheat clear for only 0.5 s of 2 s", lambda: None).refused
    outcome = m.clear_fault(*ALL_CLEAR)
    assert outcome.success and m.mode is HI and "nothing restarted" in outcome.message
    assert m.allows_cmd_vel()


def test_a_hold_in_low_level_closes_the_user_stream() -> None:
    rig = make_rig(service=RELEASED)
    rig.bring_to(LO)
    rig.machine.hold(("battery_critical: 9.00 % < 10",))
    assert not rig.machine.allows_low_level_commands() and rig.machine.mode is LO


def test_low_level_is_refused_under_a_hold_on_the_release_path_too() -> None:
    rig = make_rig()
    rig.bring_to(HI)
    rig.machine.hold(("battery_critical: 9.00 % < 10",))
    outcome = rig.machine.request(LO)
    assert outcome.refused and rig.machine.mode is HI and "holds motion" in outcome.message, outcome
    assert rig.machine.request(ID).success  # other modes are not: a hold keeps them standing
