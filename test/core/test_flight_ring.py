"""The flight ring: bounded per kind, a window by time, entries in the order they were added, safe to add to
from several threads while it is read."""

from __future__ import annotations

import random
import threading
import tracemalloc

import pytest

from fakes.fake_clock import FakeClock
from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.core.recorder.events import (
    Attempt,
    BodyStep,
    DriveInput,
    EstopStep,
    Event,
    FrameSent,
    Kind,
    MoveSent,
    Note,
    OdometrySeen,
    Phase,
    RobotCall,
    ServiceAnswer,
    StatusChange,
    Verb,
)
from g1_mode_manager.core.recorder.ring import RATES_HZ, FlightRing, caps_for
from g1_mode_manager.core.records import MachineStatus, Result, TransitionRecord

#: docs/recorder.md's bound for the default window (30 s + 3 s after) with every kind at its cap.
DEFAULT_SPAN_S = 33.0
STATED_BYTES = 10 * 1024 * 1024


def _status(mode: Mode, version: int) -> StatusChange:
    return StatusChange(MachineStatus(mode, False, None, True, True, False, "", "", version=version))


def _body(tilt: float) -> BodyStep:
    return BodyStep(BodyReadings(tilt_rad=tilt), ("ok",))


def test_each_kind_keeps_at_most_its_cap_and_drops_its_oldest_first() -> None:
    clock = FakeClock()
    ring = FlightRing({**caps_for(1.0), Kind.BODY: 100, Kind.NOTE: 5}, clock)
    for i in range(1000):
        ring.add(_body(float(i)))
        clock.advance(0.001)
    ring.add(Note("info", "kept"))
    assert ring.counts()[Kind.BODY] == 100
    kept = ring.entries(0.0, clock())
    tilts = [e[2].readings.tilt_rad for e in kept if isinstance(e[2], BodyStep)]
    assert tilts == [float(i) for i in range(900, 1000)]
    assert [e[2].text for e in kept if isinstance(e[2], Note)] == ["kept"]  # a flood of one kind pushes out no other


def test_the_window_keeps_what_came_in_it_and_the_mode_it_began_in() -> None:
    clock = FakeClock(100.0)
    ring = FlightRing(caps_for(60.0), clock)
    ring.add(_status(Mode.IDLE, 1))
    clock.advance(1.0)
    ring.add(_status(Mode.HIGH_LEVEL, 2))  # 101: before the window, and the last status before it
    ring.add(_body(0.1))
    clock.advance(10.0)
    ring.add(_body(0.2))  # 111
    clock.advance(10.0)
    ring.add(_body(0.3))  # 121: after the window
    entries = ring.entries(110.0, 120.0)
    assert [type(e[2]).__name__ for e in entries] == ["StatusChange", "BodyStep"]
    assert entries[0][2].status.mode is Mode.HIGH_LEVEL
    assert entries[1][2].readings.tilt_rad == 0.2


def test_prune_drops_what_came_before_the_cut_and_keeps_the_mode_the_window_began_in() -> None:
    clock = FakeClock(100.0)
    ring = FlightRing(caps_for(600.0), clock)  # caps far above what a slow load fills: only the cut limits it
    ring.add(_status(Mode.IDLE, 1))
    clock.advance(1.0)
    ring.add(_status(Mode.HIGH_LEVEL, 2))  # 101: the last status before the cut
    for _ in range(50):  # 101.0 to 109.8
        ring.add(_body(0.1))
        clock.advance(0.18)
    clock.advance(111.0 - clock())
    ring.add(_body(0.2))  # 111
    assert ring.prune(110.0) == 1 + 50
    assert ring.counts()[Kind.STATUS] == 1 and ring.counts()[Kind.BODY] == 1
    entries = ring.entries(110.0, clock())
    assert [type(e[2]).__name__ for e in entries] == ["StatusChange", "BodyStep"]
    assert entries[0][2].status.mode is Mode.HIGH_LEVEL and entries[1][2].readings.tilt_rad == 0.2
    assert ring.prune(110.0) == 0


def test_entries_come_in_the_order_they_were_added_across_kinds() -> None:
    clock = FakeClock()
    ring = FlightRing(caps_for(10.0), clock)
    added = []
    for i in range(30):
        event = (_body(float(i)), Note("info", str(i)), _status(Mode.HIGH_LEVEL, i))[i % 3]
        ring.add(event)
        added.append(event)
        if i % 4 == 0:  # several events at one clock reading: their order of adding decides
            clock.advance(0.01)
    entries = ring.entries(0.0, clock())
    assert [e[2] for e in entries] == added
    assert [e[0] for e in entries] == sorted(e[0] for e in entries)


def test_caps_cover_the_span_at_each_kinds_rate() -> None:
    caps = caps_for(33.0)
    assert caps[Kind.BODY] == 3300 and caps[Kind.CALL] == 33 * RATES_HZ[Kind.CALL]
    assert caps_for(0.001)[Kind.ESTOP] == 1
    with pytest.raises(ValueError, match="span"):
        caps_for(0.0)


def test_threads_add_while_the_ring_is_read() -> None:
    ring = FlightRing(caps_for(1.0))  # BODY holds 100
    stop = threading.Event()
    errors: list[BaseException] = []

    def add() -> None:
        try:
            while not stop.is_set():
                ring.add(_body(0.0))
        except BaseException as exc:  # reported below
            errors.append(exc)

    threads = [threading.Thread(target=add) for _ in range(3)]
    for t in threads:
        t.start()
    try:
        for _ in range(300):
            assert len(ring.entries(float("-inf"), float("inf"))) <= sum(ring.caps.values())
    finally:
        stop.set()
        for t in threads:
            t.join()
    assert errors == []
    assert ring.counts()[Kind.BODY] == 100


def _typical(kind: Kind, i: int) -> Event:
    """An event as the node makes it, with fresh numbers (as a hook's thread makes them) and texts of a usual length."""
    r = random.random
    match kind:
        case Kind.STATUS:
            return StatusChange(MachineStatus(Mode.FAULT, False, None, True, True, False, "set_mode refused: FAULT", "",
                                              version=i, faults=("tilt: 1.20 rad > 1.00",)))
        case Kind.TRANSITION:
            return Attempt(TransitionRecord(Mode.IDLE, Mode.HIGH_LEVEL, Result.OK, r(), f"service active ({i})"))
        case Kind.NOTE:
            return Note("warn", f"cmd_vel dropped: mode is FAULT, velocity commands pass only in HIGH_LEVEL ({i})")
        case Kind.SERVICE:
            return ServiceAnswer("loco_command", f"start {i}", True, "code 0: fsm 500 seen after 0.42 s")
        case Kind.CALL:
            return RobotCall(i, Verb("SetVelocity", 7105, ("vx", "vy", "wz", "duration_s")), (r(), r(), r(), 1.0),
                             Phase.ANSWER, 0, None, r())
        case Kind.BODY:
            return BodyStep(BodyReadings(r(), r(), r(), 3, r(), 2, r(), 1, r(), r()), ("ok",) * 10)
        case Kind.DRIVE:
            return DriveInput("teleop", r(), r(), r(), True)
        case Kind.MOVE:
            return MoveSent("teleop", r(), r(), r())
        case Kind.ESTOP:
            return EstopStep("answer", "/g1_mode_manager/estop", f"success=True: e-stop: robot damped ({i})")
        case Kind.FRAME:
            return FrameSent.of("lowcmd", [MotorCommand(r(), r(), r(), r(), r()) for _ in range(29)])
        case Kind.ODOMETRY:  # the tuples the odometry reader made for its sample
            return OdometrySeen((r(), r(), r()), r(), (r(), r(), r(), r()))


def test_a_full_ring_of_the_default_window_takes_at_most_the_stated_bytes() -> None:
    caps = caps_for(DEFAULT_SPAN_S)
    tracemalloc.start()
    try:
        before = tracemalloc.take_snapshot()
        ring = FlightRing(caps)
        for kind in Kind:
            for i in range(caps[kind]):
                ring.add(_typical(kind, i))
        used = sum(s.size_diff for s in tracemalloc.take_snapshot().compare_to(before, "filename"))
    finally:
        tracemalloc.stop()
    assert ring.counts() == caps
    print(f"a full ring: {sum(caps.values())} events, {used / 1e6:.1f} MB, {ring.approx_bytes() / 1e6:.1f} MB counted")
    assert used <= STATED_BYTES
    assert abs(ring.approx_bytes() - used) <= 0.25 * used  # the count /diagnostics and the soak read
