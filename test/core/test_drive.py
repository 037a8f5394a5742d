"""Who drives: the rules of core/drive.py, without a relay."""

from __future__ import annotations

from g1_mode_manager.core.drive import DriveArbiter, Driver
from g1_mode_manager.core.velocity import ZERO, Velocity

FORWARD = Velocity(0.3, 0.0, 0.0)


def test_the_teleop_drives_until_the_autonomy_is_handed_the_robot() -> None:
    arbiter = DriveArbiter()
    assert arbiter.driver is Driver.TELEOP
    assert not arbiter.offer(Driver.AUTONOMY, FORWARD).taken  # a planner alone never drives
    assert arbiter.offer(Driver.TELEOP, FORWARD).taken
    assert arbiter.hand_over() and arbiter.driver is Driver.AUTONOMY
    assert not arbiter.hand_over()  # already
    assert arbiter.offer(Driver.AUTONOMY, FORWARD).taken


def test_a_non_zero_teleop_command_takes_over_and_a_zero_one_does_not() -> None:
    arbiter = DriveArbiter()
    arbiter.hand_over()
    changes = arbiter.changes
    assert arbiter.offer(Driver.TELEOP, ZERO) == arbiter.offer(Driver.TELEOP, ZERO)
    assert not arbiter.offer(Driver.TELEOP, ZERO).taken  # a joystick at rest publishes zeros
    assert arbiter.driver is Driver.AUTONOMY and arbiter.changes == changes
    offer = arbiter.offer(Driver.TELEOP, Velocity(0.0, 0.0, 0.01))
    assert offer.taken and offer.took_over
    assert arbiter.driver is Driver.TELEOP and arbiter.changes == changes + 1
    assert "teleop" in arbiter.last_change
    assert not arbiter.offer(Driver.AUTONOMY, FORWARD).taken  # back only by a new hand-over


def test_take_over_ends_the_autonomy_and_says_whether_it_drove() -> None:
    arbiter = DriveArbiter()
    assert not arbiter.take_over("operator")  # the teleop drives already: no change
    arbiter.hand_over()
    assert arbiter.take_over("HIGH_LEVEL left for EMERGENCY")
    assert arbiter.driver is Driver.TELEOP and arbiter.last_change == "HIGH_LEVEL left for EMERGENCY"
