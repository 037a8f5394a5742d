"""The console's dead-man and driver lock, on a fake clock: a page drives only while it is visible, focused,
holds a key or the stick and its heartbeat is fresh; one page drives at a time; letting go in any way stops
publishing at the next tick (the mode manager's watchdog then stops the robot)."""

from __future__ import annotations

import pytest

from fakes.fake_clock import FakeClock
from g1_mode_manager.console.deadman import DeadMan
from g1_mode_manager.console.driver_lock import DriverLock
from g1_mode_manager.console.messages import Teleop as Msg
from g1_mode_manager.console.teleop import Limits, Teleop

DEADLINE = 0.3
LIMITS = Limits(0.5, 0.3, 0.8)


def held(vx: float = 1.0, *, visible: bool = True, focused: bool = True) -> Msg:
    return Msg(visible, focused, vx, 0.0, 0.0, 0)


def test_dead_man_holds_only_while_every_condition_does() -> None:
    clock = FakeClock()
    dm = DeadMan(DEADLINE)
    assert dm.why_not(clock()) == "no heartbeat yet"
    dm.heard(held(), clock())
    assert dm.axes(clock()) == (1.0, 0.0, 0.0)
    clock.advance(DEADLINE - 0.01)
    assert dm.why_not(clock()) is None
    clock.advance(0.02)
    assert dm.why_not(clock()).startswith("heartbeat late")
    assert dm.axes(clock()) is None
    for msg, why in ((held(visible=False), "page hidden"), (held(focused=False), "window not focused"),
                     (held(0.0), "no key or stick held")):
        dm.heard(msg, clock())
        assert dm.why_not(clock()) == why
        assert dm.axes(clock()) is None
    dm.heard(held(), clock())
    dm.close()
    assert dm.why_not(clock()) == "socket closed"
    with pytest.raises(ValueError):
        DeadMan(0.0)


def test_driver_lock_is_kept_between_taps_and_released_when_idle_or_closed() -> None:
    lock = DriverLock(idle_release_s=2.0)
    assert lock.claim("a", 0.0)
    assert not lock.claim("b", 1.0)
    assert lock.holder(1.9) == "a"
    assert lock.claim("a", 1.9)  # driving again keeps it
    assert not lock.claim("b", 3.8)
    assert lock.claim("b", 4.0)  # a idle for 2.1 s: free
    lock.release("a")  # not the holder: nothing changes
    assert lock.holder(4.0) == "b"
    lock.release("b")
    assert lock.holder(4.0) is None


def test_a_page_that_lets_go_stops_publishing_at_the_next_tick() -> None:
    clock = FakeClock()
    teleop = Teleop(DEADLINE, 2.0, LIMITS)
    teleop.join("p1", "console 1")
    assert teleop.tick(clock()) is None
    teleop.heard("p1", Msg(True, True, 1.0, -1.0, 0.5, 1), clock())
    assert teleop.tick(clock()) == (0.5, -0.3, 0.4)  # scaled by the console's limits
    assert teleop.status("p1", clock()).publishing and teleop.status("p1", clock()).you_drive
    # each way of letting go
    for msg in (held(visible=False), held(focused=False), held(0.0)):
        teleop.heard("p1", msg, clock())
        assert teleop.tick(clock()) is None
        teleop.heard("p1", held(), clock())
        assert teleop.tick(clock()) is not None
    clock.advance(DEADLINE + 0.01)  # heartbeat late: the last message still said "W held"
    assert teleop.tick(clock()) is None
    assert teleop.status("p1", clock()).why_not.startswith("heartbeat late")
    teleop.heard("p1", held(), clock())
    assert teleop.tick(clock()) is not None
    teleop.leave("p1")  # socket lost
    assert teleop.tick(clock()) is None


def test_nobody_drives_while_the_node_would_drop_cmd_vel() -> None:
    clock = FakeClock()
    teleop = Teleop(DEADLINE, 2.0, LIMITS)
    teleop.join("p1", "console 1")
    teleop.heard("p1", held(), clock())
    assert teleop.tick(clock(), blocked="IDLE: driving needs HIGH_LEVEL") is None
    status = teleop.status("p1", clock(), blocked="IDLE: driving needs HIGH_LEVEL")
    assert status.why_not == "IDLE: driving needs HIGH_LEVEL" and not status.publishing


def test_one_page_drives_and_the_others_are_told_who() -> None:
    clock = FakeClock()
    teleop = Teleop(DEADLINE, 1.0, LIMITS)
    teleop.join("p1", "console 1 (127.0.0.1)")
    teleop.join("p2", "console 2 (127.0.0.1)")
    teleop.heard("p1", held(1.0), clock())
    teleop.heard("p2", held(-1.0), clock())
    assert teleop.tick(clock()) == (0.5, 0.0, 0.0)  # the first to hold a key
    other = teleop.status("p2", clock())
    assert other.driver == "console 1 (127.0.0.1)" and not other.you_drive and not other.publishing
    assert other.why_not == "console 1 (127.0.0.1) drives"
    # console 1 lets go: it keeps the lock for the release time, so console 2 still does not drive
    teleop.heard("p1", held(0.0), clock())
    clock.advance(0.1)
    teleop.heard("p1", held(0.0), clock())
    teleop.heard("p2", held(-1.0), clock())
    assert teleop.tick(clock()) is None
    clock.advance(1.0)
    teleop.heard("p1", held(0.0), clock())
    teleop.heard("p2", held(-1.0), clock())
    assert teleop.tick(clock()) == (-0.5, 0.0, 0.0)
    assert teleop.status("p1", clock()).why_not == "no key or stick held"
    assert teleop.status("p1", clock()).driver == "console 2 (127.0.0.1)"
    # the driver's socket closes: the lock is free at once
    teleop.leave("p2")
    teleop.heard("p1", held(1.0), clock())
    assert teleop.tick(clock()) == (0.5, 0.0, 0.0)
    assert teleop.driving() == "console 1 (127.0.0.1)"
