"""g1ctl drive is a dead-man switch: a key drives for a hold time; with no key nothing is published."""

from __future__ import annotations

from g1_mode_manager.cli.keyboard import HOLD_S, DriveState


def test_a_key_drives_for_the_hold_time_then_nothing_is_published() -> None:
    state = DriveState()
    assert state.command(0.0) is None  # nothing pressed yet: silence
    state.apply("w", 10.0)
    assert state.command(10.0) == (state.speed, 0.0, 0.0)
    assert state.command(10.0 + HOLD_S - 0.01) == (state.speed, 0.0, 0.0)
    assert state.command(10.0 + HOLD_S + 0.01) is None  # let go: the node's watchdog stops the robot
    assert state.command(100.0) is None


def test_key_repeat_keeps_driving_and_a_new_key_replaces_the_velocity() -> None:
    state = DriveState()
    for i in range(20):  # a held key repeats every 33 ms
        state.apply("q", 1.0 + 0.033 * i)
    assert state.command(1.0 + 0.033 * 19 + HOLD_S / 2) == (0.0, 0.0, state.turn_speed)
    state.apply("d", 3.0)
    assert state.command(3.0) == (0.0, -state.speed, 0.0)


def test_space_sends_zero_once_and_x_asks_for_an_estop() -> None:
    state = DriveState()
    state.apply("w", 0.0)
    assert state.apply(" ", 0.1) is None
    assert state.command(0.1) == (0.0, 0.0, 0.0)
    assert state.command(0.2) is None
    state.apply("w", 1.0)
    assert state.apply("x", 1.1) == "estop"
    assert state.command(1.1) == (0.0, 0.0, 0.0) and state.command(1.2) is None
    assert state.apply("\x03", 2.0) == "quit"
