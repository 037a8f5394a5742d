"""LowStateDemand: rt/lowstate is received in every mode but a settled HIGH_LEVEL with nothing needing it."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import pytest

from fakes.fake_clock import FakeClock
from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.core.records import MachineStatus
from g1_mode_manager.relay.link_health import LinkHealth
from g1_mode_manager.relay.lowstate_demand import HOLD_S, LowStateDemand

HIGH = MachineStatus(mode=Mode.HIGH_LEVEL, transition_in_progress=False, transition_target=None, service_known=True,
                     service_active=True, damp_confirmed=False, last_refusal="", last_error="")


@dataclass
class Rig:
    status: MachineStatus = HIGH
    arms: bool = False
    link: bool = True
    clock: FakeClock = field(default_factory=lambda: FakeClock(start=100.0))


@pytest.fixture
def rig():
    state = Rig()
    port = FakeRobotPort()
    machine = type("Machine", (), {"status": lambda _self: state.status})()
    demand = LowStateDemand(port, machine, lambda: state.arms, lambda _mode: state.link, always=False,
                            clock=state.clock)
    return state, port, demand


def settle(state: Rig, demand: LowStateDemand) -> None:
    demand.update()
    state.clock.advance(HOLD_S + 0.1)
    demand.update()


def test_settled_high_level_unsubscribes_only_after_the_hold(rig) -> None:
    state, port, demand = rig
    demand.update()
    assert port.lowstate_wanted  # within the hold after start
    settle(state, demand)
    assert not port.lowstate_wanted


@pytest.mark.parametrize("mode", [Mode.IDLE, Mode.LOW_LEVEL, Mode.EMERGENCY, Mode.UNINITIALIZED])
def test_every_other_mode_receives_it(rig, mode: Mode) -> None:
    state, port, demand = rig
    settle(state, demand)
    state.status = replace(HIGH, mode=mode)
    demand.update()
    assert port.lowstate_wanted
    state.clock.advance(60.0)
    demand.update()
    assert port.lowstate_wanted


def test_a_transition_a_target_arms_and_a_lost_link_subscribe_at_once(rig) -> None:
    state, port, demand = rig
    for make_need, clear in (
        (lambda: setattr(state, "status", replace(HIGH, transition_in_progress=True, transition_target=Mode.IDLE)),
         lambda: setattr(state, "status", HIGH)),
        (lambda: setattr(state, "arms", True), lambda: setattr(state, "arms", False)),
        (lambda: setattr(state, "link", False), lambda: setattr(state, "link", True)),
    ):
        settle(state, demand)
        assert not port.lowstate_wanted
        make_need()
        demand.update()
        assert port.lowstate_wanted
        clear()
    settle(state, demand)
    demand.update(Mode.LOW_LEVEL)  # set_mode names its target before the machine starts the transition
    assert port.lowstate_wanted


def test_joint_states_keep_it_always(rig) -> None:
    state, port, _ = rig
    always = LowStateDemand(port, type("M", (), {"status": lambda _s: state.status})(), lambda: False,
                            lambda _mode: True, always=True, clock=state.clock)
    settle(state, always)
    assert port.lowstate_wanted


class _Gate:
    def __init__(self, mode: Mode) -> None:
        self.mode = mode


@pytest.mark.parametrize("mode", [Mode.HIGH_LEVEL, Mode.IDLE, Mode.LOW_LEVEL, Mode.EMERGENCY])
def test_link_without_lowstate_is_judged_by_sportmodestate_in_high_level_only(mode: Mode) -> None:
    port = FakeRobotPort()
    port.lowstate_age = 30.0  # the last sample before unsubscribing
    port.set_lowstate_wanted(False)
    report = LinkHealth(port, _Gate(mode), 0.5).report()
    if mode is Mode.HIGH_LEVEL:
        assert report.ok and report.lowstate_age_s is None
        port.sport = replace(port.sport, age_s=1.0)
        assert not LinkHealth(port, _Gate(mode), 0.5).report().ok  # the service's stream went silent
    else:
        assert not report.ok and "rt/lowstate" in report.reason


@pytest.mark.parametrize("mode", list(Mode))
def test_link_ok_answers_what_the_full_report_says(mode: Mode) -> None:
    """link_ok (asked before every forwarded frame) is the report's verdict in every case, without the report."""
    port = FakeRobotPort()
    for receiving in (True, False):
        for low in (None, 0.01, 0.49, 0.51, 30.0):
            for sport in (None, 0.01, 0.51):
                port.set_lowstate_wanted(receiving)
                port.lowstate_age = low
                port.sport = None if sport is None else SportState(4, 0, 0, 0.0, sport)
                link = LinkHealth(port, _Gate(mode), 0.5)
                assert link.link_ok(mode) == link.report().ok, (receiving, low, sport)
