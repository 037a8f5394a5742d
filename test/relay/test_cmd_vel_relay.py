"""The /cmd_vel relay against the fake robot port: gate, limiter on acknowledged Moves only, StopMove, dead band."""

from __future__ import annotations

import itertools
import math
import time

import pytest
from relay_fakes import Gate, moves, run_steps

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.protocol import api_ids
from g1_mode_manager.relay.cmd_vel import STOP_ATTEMPTS, CmdVelRelay
from g1_mode_manager.relay.link_health import LinkHealth
from support.mode_manager import wait_until

LIMITS = VelocityLimits(max_vx=0.8, max_vy=0.4, max_wz=1.0, max_ax=1.0, max_ay=1.0, max_awz=2.0)
PERIOD = 0.05  # rate_hz 20: the limiter's largest dt
STOP = (0.0, 0.0, 0.0, 1.0)


def _relay(port, gate, events, clock, timeout_s=0.3, max_rate_hz=50.0) -> CmdVelRelay:
    return CmdVelRelay(port, gate, LinkHealth(port, gate, 0.5), events, limits=LIMITS, timeout_s=timeout_s,
                       move_duration_s=1.0, rate_hz=1.0 / PERIOD, max_rate_hz=max_rate_hz, clock=clock)


def _moves(port) -> list[tuple]:
    return moves(port)


def _run(relay, clock, n, dt=PERIOD) -> None:
    run_steps(relay, clock, n, dt)


def test_dropped_outside_high_level_with_warning_naming_the_mode_and_never_sent_later(events, logs, clock) -> None:
    port = FakeRobotPort()
    for mode in (Mode.UNINITIALIZED, Mode.IDLE, Mode.LOW_LEVEL, Mode.EMERGENCY):
        gate = Gate(mode)
        relay = _relay(port, gate, events, clock)
        relay.submit(0.5, 0.0, 0.0)
        relay.step()  # the forward gate refuses: the command taken since the last step is dropped
        relay.step()  # nothing new taken: nothing more dropped
        gate.mode = Mode.HIGH_LEVEL
        _run(relay, clock, 2, dt=0.01)  # the dropped command and its stream are forgotten
    assert _moves(port) == []
    assert events.counts()["cmd_vel_dropped"] == 4
    assert ("warn", "cmd_vel dropped: mode is UNINITIALIZED, velocity commands pass only in HIGH_LEVEL") in logs


def test_ramps_at_the_acceleration_limit_latest_wins_and_one_stop_move_on_silence(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    relay.submit(0.2, 0.0, 0.0)
    relay.submit(0.8, 0.0, 0.0)  # latest wins: the 0.2 is never sent
    relay.step()
    _run(relay, clock, 3)
    assert [m[0] for m in _moves(port)] == pytest.approx([0.05, 0.10, 0.15, 0.20])  # 1 m/s^2 * 0.05 s
    assert all(m[3] == 1.0 for m in _moves(port))
    clock.advance(1.0)  # silence
    _run(relay, clock, 5)
    assert _moves(port)[4:] == [STOP]
    assert events.counts()["stop_moves_sent"] == 1


def test_refused_moves_do_not_advance_the_ramp(events, clock) -> None:
    # In lock stand (fsm 4) the robot refuses Move: after `loco start` the first accepted Move must
    # still be one acceleration step from standstill, not the 0.8 the ramp would have reached.
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock, timeout_s=10.0)
    port.fail_stream["set_velocity"] = api_ids.ERR_REFUSED_IN_STATE
    relay.submit(0.8, 0.0, 0.0)
    _run(relay, clock, 40)
    del port.fail_stream["set_velocity"]
    _run(relay, clock, 1)
    assert _moves(port)[-1][0] == pytest.approx(0.05)


def test_a_stalled_sender_ramps_slower_never_jumps(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock, timeout_s=10.0)
    relay.submit(0.8, 0.0, 0.0)
    _run(relay, clock, 2)
    _run(relay, clock, 1, dt=0.5)  # the thread was not scheduled for 0.5 s
    vx = [m[0] for m in _moves(port)]
    assert max(b - a for a, b in itertools.pairwise(vx)) <= LIMITS.max_ax * PERIOD + 1e-9


def test_a_timed_out_move_counts_as_maybe_moving_and_gets_a_stop_move(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    port.fail_stream["set_velocity"] = api_ids.ERR_CLIENT_API_TIMEOUT  # sent, executed, answer lost
    relay.submit(0.5, 0.0, 0.0)
    relay.step()
    del port.fail_stream["set_velocity"]
    clock.advance(1.0)
    relay.step()
    assert _moves(port)[-1] == STOP


def test_stop_move_is_repeated_until_acknowledged(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    relay.submit(0.5, 0.0, 0.0)
    relay.step()
    port.fail_stream["set_velocity"] = api_ids.ERR_CLIENT_API_TIMEOUT
    clock.advance(1.0)
    _run(relay, clock, 2)
    del port.fail_stream["set_velocity"]
    _run(relay, clock, 5)
    assert _moves(port)[1:] == [STOP] * 3  # two lost, the third acknowledged, then nothing more


def test_stop_move_retries_are_bounded(events, logs, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    relay.submit(0.5, 0.0, 0.0)
    relay.step()
    port.fail_stream["set_velocity"] = api_ids.ERR_CLIENT_API_TIMEOUT
    clock.advance(1.0)
    _run(relay, clock, 3 * STOP_ATTEMPTS)
    assert _moves(port)[1:] == [STOP] * STOP_ATTEMPTS
    assert any("stops by itself" in text for _, text in logs)


def test_stops_when_mode_leaves_high_level_or_link_is_lost(events, clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events, clock)
    relay.submit(0.5, 0.0, 0.0)
    relay.step()
    gate.in_transition = True  # a transition away has started
    _run(relay, clock, 2)
    assert _moves(port)[1:] == [STOP]
    gate.in_transition = False
    relay.submit(0.5, 0.0, 0.0)
    _run(relay, clock, 1)
    port.lowstate_age = 5.0  # link lost
    _run(relay, clock, 1)
    assert _moves(port)[-1] == STOP


def test_a_closed_forward_gate_sends_no_move(events, clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events, clock)
    relay.submit(0.5, 0.0, 0.0)
    gate.forward_refuses = True  # an e-stop began between the check and the send
    relay.step()
    assert _moves(port) == []


def test_sub_dead_band_commands_are_not_sent_forever(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock, timeout_s=100.0)
    for _ in range(40):  # a teleop publishing a creep the robot ignores
        relay.submit(0.05, 0.0, 0.05)
        _run(relay, clock, 1)
    assert _moves(port) == []
    relay.submit(0.3, 0.0, 0.0)
    _run(relay, clock, 6)
    for _ in range(40):  # then zero, still published: one StopMove, then silence on the RPC
        relay.submit(0.0, 0.0, 0.0)
        _run(relay, clock, 1)
    moves = _moves(port)
    assert moves[-1] == STOP and moves.count(STOP) == 1
    top = max(range(len(moves)), key=lambda i: moves[i][0])
    assert all(m[0] >= 0.1 for m in moves[top:-1])  # slowing down: the last sub-band steps became the StopMove


def test_shutdown_sends_stop_move_while_moving(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock)
    relay.submit(0.5, 0.0, 0.0)
    relay.step()
    relay.stop()
    assert _moves(port)[-1] == STOP


@pytest.mark.parametrize("duration", [0.0, 2.5, 864000.0, math.inf, math.nan])
def test_move_lease_longer_than_two_seconds_is_refused(events, clock, duration) -> None:
    port = FakeRobotPort()
    with pytest.raises(ValueError, match="move duration"):
        CmdVelRelay(port, Gate(Mode.HIGH_LEVEL), LinkHealth(port, Gate(Mode.HIGH_LEVEL), 0.5), events,
                    limits=LIMITS, timeout_s=0.5, move_duration_s=duration, rate_hz=20.0, max_rate_hz=50.0)


def test_nan_sends_zero_and_huge_is_clamped(events, logs, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock, timeout_s=100.0)
    assert relay.submit(math.nan, 0.0, 0.0).rejected
    relay.step()
    assert _moves(port) == []  # zero while standing: nothing to send
    assert relay.submit(1e9, -1e9, math.inf).rejected
    assert relay.submit(1e9, -1e9, 5.0).clamped
    _run(relay, clock, 30)
    assert _moves(port)[-1][:3] == pytest.approx((0.8, -0.4, 1.0))
    counts = events.counts()
    assert counts["cmd_vel_rejected"] == 2 and counts["cmd_vel_clamped"] == 1
    assert any("non-finite" in text for _, text in logs)


def test_sender_thread_sends_on_arrival_without_waiting_for_a_tick(events) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, time.monotonic, timeout_s=100.0)
    relay._period_s = 1000.0  # no keep-alive tick in this test: only an arrival can send
    relay.start()
    try:
        relay.submit(0.5, 0.0, 0.0)
        assert wait_until(lambda: len(_moves(port)) == 1, 5.0)
    finally:
        relay.stop()


def test_sender_thread_caps_the_move_rate(events) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, time.monotonic, timeout_s=100.0, max_rate_hz=20.0)
    relay.start()
    try:
        t0 = time.monotonic()
        while time.monotonic() - t0 < 0.5:  # a 1 kHz publisher
            relay.submit(0.5, 0.0, 0.0)
            time.sleep(0.001)
        elapsed = time.monotonic() - t0
    finally:
        relay.stop()
    moves = [m for m in _moves(port) if m != STOP]
    assert 1 <= len(moves) <= elapsed * 20.0 + 2


def test_a_new_command_right_after_a_keep_alive_goes_at_once_and_the_cap_holds_over_time(events, clock) -> None:
    """The Move budget is a token bucket of MOVE_BURST refilled at max_rate_hz: a keep-alive does not hold
    back the next new command, and back-to-back Moves beyond the burst wait for the budget."""
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock, timeout_s=100.0, max_rate_hz=50.0)
    relay.submit(0.1, 0.0, 0.0)
    relay.step()
    assert len(_moves(port)) == 1  # a Move (say, a keep-alive) just went out
    assert relay._budget_wait() == 0.0  # a new command now is not held back
    relay.submit(0.05, 0.0, 0.0)
    relay.step()
    assert len(_moves(port)) == 2
    assert relay._budget_wait() == pytest.approx(1.0 / 50.0)  # the burst is spent: the next waits 20 ms
    clock.advance(0.01)
    assert relay._budget_wait() == pytest.approx(0.01)
    clock.advance(0.01)
    assert relay._budget_wait() == 0.0
    clock.advance(10.0)  # a long pause refills no more than the burst
    relay._spend()
    relay._spend()
    assert relay._budget_wait() == pytest.approx(1.0 / 50.0)


def test_ramp_steps_every_50_ms_a_steady_move_at_the_keep_alive_and_the_watchdog_at_its_deadline(events,
                                                                                               clock) -> None:
    """rate_hz 10 (the default): while the limiter ramps the sender steps every 50 ms; once the robot runs the
    command, every 100 ms; and silence is acted on at the watchdog's deadline, not at the next tick."""
    port = FakeRobotPort()
    relay = CmdVelRelay(port, Gate(Mode.HIGH_LEVEL), LinkHealth(port, Gate(Mode.HIGH_LEVEL), 0.5), events,
                        limits=LIMITS, timeout_s=0.5, move_duration_s=1.0, rate_hz=10.0, max_rate_hz=50.0,
                        clock=clock)
    relay.submit(0.1, 0.0, 0.0)
    relay.step()  # first step of the ramp: 0.05 of 0.1 (1 m/s^2 over 50 ms)
    assert [m[0] for m in _moves(port)] == pytest.approx([0.05])
    assert relay._next_step_in(clock()) == pytest.approx(0.05)  # still ramping
    for _ in range(2):  # 0.05 s of float clock is a hair less than 0.05: a last step lands exactly on 0.1
        clock.advance(0.05)
        relay.step()
    assert _moves(port)[-1][0] == 0.1
    assert relay._next_step_in(clock()) == pytest.approx(0.1)  # the robot runs the command: keep-alive
    clock.advance(0.39)  # the last command came 0.49 s ago: the watchdog (0.5 s) comes before the next tick
    assert relay._next_step_in(clock() - 0.04) == pytest.approx(0.011)
    clock.advance(0.011)
    relay.step()
    assert _moves(port)[-1] == STOP  # the watchdog's StopMove, 1 ms after its deadline


@pytest.mark.parametrize("stop", [Mode.EMERGENCY, Mode.FAULT])
def test_a_stop_move_refused_by_the_robot_a_stop_damped_is_expected_not_an_error(events, logs, clock, stop) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events, clock)
    relay.submit(0.5, 0.0, 0.0)
    relay.step()
    port.fail_stream["set_velocity"] = api_ids.ERR_REFUSED_IN_STATE  # the Damp reached the robot first
    gate.mode = stop
    _run(relay, clock, 4)
    assert _moves(port)[1:] == [STOP]  # still sent once (it stops a robot whose Damp failed), never repeated
    assert not [text for level, text in logs if level == "error"]
    assert any(level == "info" and "as expected" in text for level, text in logs)


def test_a_stop_move_refused_outside_a_stop_is_still_an_error(events, logs, clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events, clock)
    relay.submit(0.5, 0.0, 0.0)
    relay.step()
    port.fail_stream["set_velocity"] = api_ids.ERR_REFUSED_IN_STATE
    gate.mode = Mode.IDLE
    _run(relay, clock, 4)
    assert any(level == "error" and "StopMove" in text for level, text in logs)


def test_the_keep_alive_goes_out_every_period_when_the_write_comes_after_the_steps_start(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events, clock, timeout_s=60.0)
    sent: list[float] = []
    send, plan = port.send_velocity, relay._plan

    def slow_plan(*args):  # the step's work between its clock reading and the write (the plan, the gate)
        planned = plan(*args)
        clock.advance(0.0003)
        return planned

    def send_at(*args):
        sent.append(clock())
        return send(*args)

    relay._plan, port.send_velocity = slow_plan, send_at
    relay.submit(0.3, 0.0, 0.0)
    for _ in range(80):
        last_step = clock()
        relay.step()
        clock.advance(relay._next_step_in(last_step) + 0.0001)  # the sender's wake, a little late
    steady = [b - a for a, b in itertools.pairwise(sent[10:])]  # past the ramp (0.3 m/s at 1 m/s^2)
    assert steady and max(steady) < 1.5 * PERIOD, steady
