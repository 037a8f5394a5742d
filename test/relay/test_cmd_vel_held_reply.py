"""A Move whose reply the robot holds back never holds the mode machine: the forward gate covers the
write, and the wait for the acknowledgement happens after it.

The real ModeMachine and CmdVelRelay against the fake port, in real threads; the end-to-end version of
this (the sim holding every Move's reply for 2 s) is in test/e2e/test_held_move.py.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.machine import ModeMachine, Outcome
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.relay.cmd_vel import CmdVelRelay
from g1_mode_manager.relay.link_health import LinkHealth
from support.mode_manager import wait_until

LIMITS = VelocityLimits(0.8, 0.4, 1.0, 1.0, 1.0, 2.0)
#: Far longer than any of the machine's own steps on the fake port take; the held reply lasts 10 s.
BOUND_S = 2.0


def _walking_with_a_held_reply() -> tuple[ModeMachine, FakeRobotPort, CmdVelRelay, threading.Event]:
    port = FakeRobotPort()
    machine = ModeMachine(port)
    assert machine.request(Mode.HIGH_LEVEL).success
    hold = threading.Event()
    port.move_reply_hold = hold
    relay = CmdVelRelay(port, machine, LinkHealth(port, machine, 0.5), RelayEvents(lambda *_: None),
                        limits=LIMITS, timeout_s=5.0, move_duration_s=1.0, rate_hz=10.0, max_rate_hz=50.0)
    machine.add_leave_listener(relay.on_leave)
    relay.start()
    relay.submit(0.5, 0.0, 0.0)
    assert wait_until(lambda: len(port.stream("set_velocity")) >= 1, 5.0), "no Move was written"
    return machine, port, relay, hold


def _in_thread(call: Callable[[], Outcome]) -> tuple[threading.Thread, list[Outcome]]:
    out: list[Outcome] = []
    thread = threading.Thread(target=lambda: out.append(call()), daemon=True)
    thread.start()
    return thread, out


def test_set_mode_is_not_held_by_a_move_awaiting_its_reply() -> None:
    machine, _port, relay, hold = _walking_with_a_held_reply()
    try:
        thread, out = _in_thread(lambda: machine.request(Mode.IDLE))
        thread.join(BOUND_S)
        assert not thread.is_alive(), "set_mode waited for the Move's reply"
        assert not hold.is_set() and out[0].success and machine.mode is Mode.IDLE, out
    finally:
        hold.set()
        relay.stop()


def test_estop_registers_at_once_beside_a_move_awaiting_its_reply() -> None:
    machine, port, relay, hold = _walking_with_a_held_reply()
    try:
        thread, out = _in_thread(machine.estop)
        thread.join(BOUND_S)
        assert not thread.is_alive(), "the e-stop waited for the Move's reply"
        assert not hold.is_set() and out[0].success, out
        assert "longer than the forward wait" not in out[0].message, out[0].message
        assert port.damped
    finally:
        hold.set()
        relay.stop()
