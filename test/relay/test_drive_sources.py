"""Two sources on the one Move stream (the cmd_vel relay against the fake robot port): the autonomy drives only
once handed the robot, within its own limits; the human takes over at once; silence and a suspension stop the
robot; leaving HIGH_LEVEL needs a new hand-over."""

from __future__ import annotations

import itertools

import pytest
from relay_fakes import Gate, moves, run_steps

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import OdomSample
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.protocol.odom_fields import OdomFields
from g1_mode_manager.relay.autonomy_conditions import AutonomyConditions
from g1_mode_manager.relay.cmd_vel import AutonomyInput, CmdVelRelay
from g1_mode_manager.relay.link_health import LinkHealth
from g1_mode_manager.relay.walk_judge import WARNING, WalkJudge

TELEOP = VelocityLimits(max_vx=0.8, max_vy=0.4, max_wz=1.0, max_ax=2.0, max_ay=2.0, max_awz=4.0)
AUTONOMY = VelocityLimits(max_vx=0.3, max_vy=0.2, max_wz=0.5, max_ax=1.0, max_ay=1.0, max_awz=2.0)
PERIOD = 0.05
STOP = (0.0, 0.0, 0.0, 1.0)


class Blocked:
    """The autonomy's conditions as a test sets them."""

    def __init__(self) -> None:
        self.why: str | None = None

    def __call__(self) -> str | None:
        return self.why


def _relay(port, gate, events, clock, blocked=None) -> CmdVelRelay:
    return CmdVelRelay(port, gate, LinkHealth(port, gate, 0.5), events, limits=TELEOP, timeout_s=0.3,
                       move_duration_s=1.0, rate_hz=1.0 / PERIOD, max_rate_hz=1000.0, clock=clock,
                       autonomy=AutonomyInput("cmd_vel_nav", AUTONOMY, 0.3),
                       autonomy_blocked=blocked or (lambda: None))


def _moves(port) -> list[tuple]:
    return moves(port)


def _run(relay, clock, n, dt=PERIOD) -> None:
    run_steps(relay, clock, n, dt)


def _autonomy(relay, vx, vy=0.0, wz=0.0):
    return relay.sources.offer(relay.sources.autonomy, vx, vy, wz)


def test_autonomy_commands_move_nothing_before_a_hand_over_and_are_counted(events, logs, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    for _ in range(5):
        _autonomy(relay, 0.3)
        _run(relay, clock, 1)
    assert _moves(port) == []
    assert events.counts()["autonomy_ignored"] == 5
    assert any("has not been handed the robot" in text for _, text in logs)
    assert relay.sources.driving(Mode.HIGH_LEVEL).driver is Driver.TELEOP


def test_after_the_hand_over_the_autonomy_drives_within_its_own_limits(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    assert relay.sources.hand_over() == (True, "the autonomy drives: commands on cmd_vel_nav move the robot")
    for _ in range(40):
        _autonomy(relay, 2.0, -2.0, 3.0)  # far over every limit
        _run(relay, clock, 1)
    moves = _moves(port)
    assert moves and moves[-1][:3] == pytest.approx((0.3, -0.2, 0.5))
    assert all(abs(vx) <= 0.3 and abs(vy) <= 0.2 and abs(wz) <= 0.5 for vx, vy, wz, _ in moves)
    steps = [b[0] - a[0] for a, b in itertools.pairwise(moves)]
    assert max(steps) <= AUTONOMY.max_ax * PERIOD + 1e-9  # its own acceleration limit
    assert events.counts()["autonomy_clamped"] == 40


def test_a_non_zero_teleop_command_takes_over_and_no_autonomy_move_follows_it(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    changes: list[Driver] = []
    relay.sources.on_driver_change = lambda: changes.append(relay.sources.driving(Mode.HIGH_LEVEL).driver)
    relay.sources.hand_over()
    for _ in range(10):
        _autonomy(relay, 0.3)
        _run(relay, clock, 1)
    before = len(_moves(port))
    relay.submit(0.0, 0.0, 0.0)  # a joystick at rest: no takeover
    _run(relay, clock, 1)
    assert relay.sources.driving(Mode.HIGH_LEVEL).driver is Driver.AUTONOMY
    relay.submit(0.0, 0.0, -0.8)  # the human turns
    assert changes == [Driver.AUTONOMY, Driver.TELEOP]  # told at once, before the sender's next step
    for _ in range(10):
        _autonomy(relay, 0.3)  # the planner goes on publishing: ignored
        relay.submit(0.0, 0.0, -0.8)
        _run(relay, clock, 1)
    after = _moves(port)[before:]
    first_teleop = next(i for i, m in enumerate(after) if m[2] != 0.0)
    assert all(m[0] == 0.0 for m in after[first_teleop:]), after  # nothing of the autonomy's vx after it
    assert after[first_teleop][2] == pytest.approx(-TELEOP.max_awz * PERIOD)  # its ramp starts from standstill
    assert events.counts()["teleop_takeovers"] == 1
    assert relay.sources.driving(Mode.HIGH_LEVEL).driver is Driver.TELEOP


def test_the_autonomy_silent_stops_the_robot_and_keeps_the_robot(events, logs, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    relay.sources.hand_over()
    # no command since the hand-over is not yet silence (the planner's next one may be on its way)
    assert relay.sources.driving(Mode.HIGH_LEVEL).autonomy_suspended == "waiting: no cmd_vel_nav since the hand-over"
    for _ in range(10):
        _autonomy(relay, 0.3)
        _run(relay, clock, 1)
    _run(relay, clock, 10)  # 0.5 s of silence, timeout 0.3 s
    assert _moves(port)[-1] == STOP
    assert ("info", "StopMove acknowledged: no cmd_vel_nav for 0.3 s") in logs
    driving = relay.sources.driving(Mode.HIGH_LEVEL)
    assert driving.driver is Driver.AUTONOMY and driving.autonomy_suspended == "silent: no cmd_vel_nav for 0.3 s"
    relay.submit(0.0, 0.0, 0.0)  # nobody else drives meanwhile
    assert relay.sources.driving(Mode.HIGH_LEVEL).driver is Driver.AUTONOMY


def test_a_suspended_autonomy_stops_the_robot_and_resumes_when_its_conditions_hold(events, clock) -> None:
    port = FakeRobotPort()
    blocked = Blocked()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock, blocked)
    relay.sources.hand_over()
    for _ in range(10):
        _autonomy(relay, 0.3)
        _run(relay, clock, 1)
    blocked.why = "odometry 0.80 s old"
    for _ in range(5):
        _autonomy(relay, 0.3)
        _run(relay, clock, 1)
    assert _moves(port)[-1] == STOP and _moves(port).count(STOP) == 1
    assert relay.sources.driving(Mode.HIGH_LEVEL).autonomy_suspended == "suspended: odometry 0.80 s old"
    blocked.why = None
    _autonomy(relay, 0.3)
    _run(relay, clock, 1)
    assert _moves(port)[-1][0] == pytest.approx(AUTONOMY.max_ax * PERIOD)  # again from standstill


def test_the_hand_over_is_refused_outside_high_level_while_held_or_blocked_and_reset_by_leaving(events,
                                                                                                clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.IDLE)
    blocked = Blocked()
    relay = _relay(port, gate, events, clock, blocked)
    gate.add_leave_listener(relay.on_leave)
    ok, why = relay.sources.hand_over()
    assert not ok and "mode is IDLE" in why
    gate.mode = Mode.HIGH_LEVEL
    gate.holds = True
    ok, why = relay.sources.hand_over()
    assert not ok and "holds motion" in why
    gate.holds = False
    blocked.why = "no odometry from the robot (rt/lf/odommodestate)"
    ok, why = relay.sources.hand_over()
    assert not ok and why.endswith("no odometry from the robot (rt/lf/odommodestate)")
    blocked.why = None
    assert relay.sources.hand_over()[0]
    gate.leave(Mode.EMERGENCY)
    assert relay.sources.driving(Mode.EMERGENCY).driver is Driver.NOBODY
    gate.leave(Mode.HIGH_LEVEL)  # (a stand-in's shortcut: the machine would pass through IDLE)
    assert relay.sources.driving(Mode.HIGH_LEVEL).driver is Driver.TELEOP


def test_the_conditions_name_stale_odometry_a_hold_and_a_robot_that_does_not_walk(clock) -> None:
    port = FakeRobotPort()
    holds: tuple[str, ...] = ()
    walk = WalkJudge(1.0)
    conditions = AutonomyConditions(port, lambda: holds, walk, odom_timeout_s=0.5, clock=clock)
    assert conditions() == "no odometry from the robot (rt/lf/odommodestate)"
    fields = OdomFields(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                        (0.0, 0.0, 0.0), 0.78)
    port.odom = OdomSample(fields, 0.9, 10)
    assert conditions() == "odometry 0.90 s old (autonomy_odom_timeout_s 0.5)"
    port.odom = OdomSample(fields, 0.05, 11)
    assert conditions() is None
    holds = ("battery_critical: 4 % < 5",)
    assert conditions() == "a body check holds motion: battery_critical: 4 % < 5"
    holds = ()
    for _ in range(30):  # Moves acknowledged, the robot's estimate does not move
        clock.advance(0.1)
        walk.acknowledged(0.5, 0.0, 0.0, clock(), port.odom)
    assert (conditions() or "").startswith(WARNING)


def test_each_input_is_told_with_whether_it_counts_and_each_move_with_who_drove_it(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    inputs: list[tuple] = []
    sent: list[tuple] = []
    relay.sources.on_input = lambda *heard: inputs.append(heard)
    relay.on_move = lambda driver, v: sent.append((driver, v.vx))
    _autonomy(relay, 0.2)  # not handed the robot: it does not count
    relay.submit(0.3, 0.0, 0.0)
    _run(relay, clock, 3)
    relay.sources.hand_over()
    _autonomy(relay, 0.2)
    _run(relay, clock, 3)
    assert inputs == [(Driver.AUTONOMY, 0.2, 0.0, 0.0, False), (Driver.TELEOP, 0.3, 0.0, 0.0, True),
                      (Driver.AUTONOMY, 0.2, 0.0, 0.0, True)]
    assert {driver for driver, _vx in sent} == {Driver.TELEOP, Driver.AUTONOMY}
    assert [driver for driver, _vx in sent] == sorted((d for d, _ in sent), key=lambda d: d is Driver.AUTONOMY)
    assert len(sent) == len([m for m in _moves(port) if any(m[:3])])  # every Move was told, no StopMove
