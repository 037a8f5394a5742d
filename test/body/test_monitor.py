"""The body checks over time, without a robot: debounce, the upright rule, reactions per mode, latching,
and when a clear is allowed."""

from __future__ import annotations

import math

import pytest

from g1_mode_manager.core.body.checks import BY_NAME, CHECKS, Reaction
from g1_mode_manager.core.body.monitor import BodyMonitor
from g1_mode_manager.core.body.readings import BodyReadings, tilt_of
from g1_mode_manager.core.modes import Mode

ID, HI, LO, FA = Mode.IDLE, Mode.HIGH_LEVEL, Mode.LOW_LEVEL, Mode.FAULT
CALM = BodyReadings(tilt_rad=0.05, gyro_max=0.1, gyro_judged=0.1, joint_speed_max=0.5, joint_speed_judged=0.5,
                    winding_max_c=40.0, casing_max_c=35.0,
                    soc_pct=90.0, state_age_s=0.002)


def _with(**changes: float) -> BodyReadings:
    return BodyReadings(**{**CALM.__dict__, **changes})


def test_the_vendor_thresholds_are_the_defaults() -> None:
    expected = {"tilt": 1.0, "spin": 6.0, "joint_speed": 10.0, "winding_overheat": 120.0, "casing_overheat": 85.0,
                "battery_low": 20.0, "state_lost": 1.0}
    assert {name: BY_NAME[name].threshold for name in expected} == expected


def test_tilt_of_an_attitude_quaternion() -> None:
    assert tilt_of(1.0, 0.0, 0.0, 0.0) == pytest.approx(0.0)
    half = 0.6  # pitched by 1.2 rad about y
    assert tilt_of(math.cos(half), 0.0, math.sin(half), 0.0) == pytest.approx(1.2)
    assert tilt_of(math.cos(0.5), 0.0, 0.0, math.sin(0.5)) == pytest.approx(0.0)  # yaw is no tilt


def test_a_fall_faults_after_its_debounce_in_every_mode_that_holds_the_robot_up() -> None:
    for mode in (ID, HI, LO):
        monitor = BodyMonitor(clear_hold_s=2.0)
        assert monitor.evaluate(_with(tilt_rad=1.2), mode, True, 10.0) == []  # within the debounce
        trips = monitor.evaluate(_with(tilt_rad=1.2), mode, True, 10.02)
        assert [(t.check, t.reaction) for t in trips] == [("tilt", Reaction.FAULT)], mode
        assert "tilt: 1.20 rad > 1" in trips[0].text


def test_a_robot_nothing_holds_up_is_not_fallen() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)
    for t in (10.0, 10.1, 10.2):
        assert monitor.evaluate(_with(tilt_rad=1.5, gyro_max=8.0, gyro_judged=8.0), HI, False, t) == []
    assert {s.check: s.state for s in monitor.statuses()}["tilt"] == "not applicable"


def test_a_flicker_shorter_than_the_debounce_does_not_trip() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)
    for t, tilt in ((10.0, 1.2), (10.005, 0.5), (10.01, 1.2), (10.015, 0.5)):
        assert monitor.evaluate(_with(tilt_rad=tilt), LO, True, t) == []


def test_overheat_holds_in_high_level_and_faults_at_the_higher_threshold() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)  # temperatures are integers without noise: one sample trips
    trips = monitor.evaluate(_with(winding_max_c=125.0), HI, True, 1.0)
    assert [(t.check, t.reaction) for t in trips] == [("winding_overheat", Reaction.HOLD)]
    assert monitor.evaluate(_with(winding_max_c=125.0), HI, True, 1.1) == []  # latched: once
    trips = monitor.evaluate(_with(winding_max_c=140.0), HI, True, 1.2)
    assert [(t.check, t.reaction) for t in trips] == [("winding_critical", Reaction.FAULT)]


def test_overheat_faults_in_low_level() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)
    trips = monitor.evaluate(_with(casing_max_c=90.0), LO, True, 1.0)
    assert [(t.check, t.reaction) for t in trips] == [("casing_overheat", Reaction.FAULT)]


def test_a_hold_that_meets_a_stronger_reaction_trips_again() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)
    hot = _with(winding_max_c=125.0)
    assert monitor.evaluate(hot, HI, True, 1.0)[0].reaction is Reaction.HOLD
    assert monitor.evaluate(hot, LO, True, 1.1)[0].reaction is Reaction.FAULT  # the mode changed


def test_battery_warns_then_holds() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)
    monitor.evaluate(_with(soc_pct=15.0), HI, True, 1.0)
    assert monitor.evaluate(_with(soc_pct=15.0), HI, True, 3.1) == []
    assert monitor.warnings() == ("battery_low: 15.00 % < 20",)
    monitor.evaluate(_with(soc_pct=8.0), HI, True, 4.0)
    trips = monitor.evaluate(_with(soc_pct=8.0), HI, True, 6.1)
    assert [(t.check, t.reaction) for t in trips] == [("battery_critical", Reaction.HOLD)]


def test_a_lost_state_stream_faults_low_level_and_warns_high_level() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)
    assert monitor.evaluate(_with(state_age_s=1.2), HI, True, 1.0) == []
    assert monitor.warnings() == ("state_lost: 1.20 s > 1",)
    trips = monitor.evaluate(_with(state_age_s=1.2), LO, True, 1.1)
    assert [(t.check, t.reaction) for t in trips] == [("state_lost", Reaction.FAULT)]


def test_an_unknown_reading_never_trips_and_never_counts_as_clear() -> None:
    monitor = BodyMonitor(clear_hold_s=0.5)
    assert monitor.evaluate(BodyReadings(), LO, True, 1.0) == []
    assert {s.state for s in monitor.statuses()} == {"no data"}
    monitor.evaluate(_with(tilt_rad=1.3), LO, True, 2.0)
    monitor.evaluate(_with(tilt_rad=1.3), LO, True, 2.1)
    monitor.evaluate(BodyReadings(), FA, True, 3.0)  # upright expected, but nothing known
    assert "tilt still active" in monitor.clearable(10.0)


def test_clear_needs_every_latched_check_clear_for_the_hold_time() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0)
    monitor.evaluate(_with(tilt_rad=1.3), LO, True, 1.0)
    assert monitor.evaluate(_with(tilt_rad=1.3), LO, True, 1.1)
    assert "tilt still active" in monitor.clearable(1.2)
    monitor.evaluate(_with(tilt_rad=1.3), FA, False, 1.5)  # damped on the floor: nothing holds it up
    assert "clear for only 0.0 s of 2 s" in monitor.clearable(1.5)
    assert monitor.clearable(3.6) == ""
    assert monitor.latched(Reaction.FAULT) == ("tilt: 1.30 rad > 1",)
    monitor.clear()
    assert monitor.latched(Reaction.FAULT) == () and not monitor.any_latched()


def test_thresholds_come_from_parameters() -> None:
    monitor = BodyMonitor(clear_hold_s=2.0, thresholds={"tilt": 0.5})
    monitor.evaluate(_with(tilt_rad=0.6), LO, True, 1.0)
    assert monitor.evaluate(_with(tilt_rad=0.6), LO, True, 1.1)
    with pytest.raises(ValueError, match="unknown body checks: tilted"):
        BodyMonitor(clear_hold_s=2.0, thresholds={"tilted": 0.5})


def test_every_check_names_a_reading_and_a_reference() -> None:
    for check in CHECKS:
        assert check.reading in BodyReadings.__dataclass_fields__, check.name
        assert check.reference and check.unit
