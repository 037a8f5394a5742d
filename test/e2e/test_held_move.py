"""A robot slow to acknowledge Moves never slows a mode change or an e-stop.

The sim holds every Move's reply for 2 s (its ``delay_s`` fault on SetVelocity, set while the robot
walks). The forward gate covers only the check and the write of a Move; the wait for its reply comes
after the gate, so neither a ``set_mode`` nor an e-stop waits behind it. Judged on the robot's record
(the e-stop's DampNoReply and its verified Damp, a Move still unanswered at that moment) and on the
durations the node logs for each transition.
"""

from __future__ import annotations

import re
import threading
import time

import pytest

from g1_mode_manager.protocol import api_ids
from support.mode_manager import wait_until
from support.sim_record import is_damp, requests, velocity_of
from support.timing import HELD_MOVE_ANSWER_S, check_latency

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

HELD_S = 2.0
HELD = {"delay_s": {str(api_ids.LOCO_SET_VELOCITY): HELD_S}}


def _logged_duration_s(stack, source: str, target: str, since: int) -> float:
    """The duration the node logged for its last ``source -> target`` transition after line ``since``."""
    pattern = re.compile(rf"transition {source} -> {target}: \w+ in (\d+) ms")
    found = [m for line in stack.node.lines[since:] for m in pattern.finditer(line)]
    assert found, f"no {source} -> {target} line in the node's log"
    return int(found[-1].group(1)) / 1000.0


def _unanswered_moves(stack, at: float, received_by: float | None = None) -> int:
    """Moves the robot had received (by ``received_by``, default ``at``) but not yet answered at ``at`` (its
    record; the sim answers one service's requests in the order they came)."""
    events = stack.record.events()
    received = [e for e in requests(events, api_ids.LOCO_SET_VELOCITY) if e["t"] <= (received_by or at)]
    answered = [e for e in requests(events, api_ids.LOCO_SET_VELOCITY, kind="done") if e["t"] <= at]
    return len(received) - len(answered)


def _walk_with_held_replies(stack, stop: threading.Event, *, start: bool) -> threading.Thread:
    assert stack.set_mode("high_level").success
    if start:
        assert stack.loco("start").success
    stack.set_faults({})
    driver = threading.Thread(target=lambda: [stack.drive(0.4, 0.2) for _ in iter(stop.is_set, True)], daemon=True)
    driver.start()
    assert wait_until(lambda: any(velocity_of(e) and velocity_of(e)[0] > 0
                                  for e in requests(stack.record.events(), api_ids.LOCO_SET_VELOCITY)), 10.0)
    stack.set_faults(HELD)
    t_held = time.monotonic()
    assert wait_until(lambda: _unanswered_moves(stack, time.monotonic()) > 0
                      and time.monotonic() - t_held > 0.3, 5.0), "no Move reply was ever held"
    return driver


def test_set_mode_and_estop_are_not_held_by_unacknowledged_moves(stack_factory) -> None:
    stack = stack_factory()
    stop = threading.Event()
    driver: threading.Thread | None = None
    try:
        # a mode change while a Move's reply is held
        driver = _walk_with_held_replies(stack, stop, start=True)
        lines = len(stack.node.lines)
        t_request = time.monotonic()
        assert _unanswered_moves(stack, t_request) > 0
        reply = stack.set_mode("idle")
        t_idle = time.monotonic() - t_request
        assert reply.success, reply.message
        # the answer came while a Move sent before the request still waited for its reply on the robot
        assert _unanswered_moves(stack, t_request + t_idle, received_by=t_request) > 0, "set_mode waited for a Move"
        assert wait_until(lambda: "HIGH_LEVEL -> IDLE" in "".join(stack.node.lines[lines:]), 5.0)
        idle_s = _logged_duration_s(stack, "HIGH_LEVEL", "IDLE", lines)
        stop.set()
        driver.join(5.0)

        # an e-stop while a Move's reply is held
        stop.clear()
        driver = _walk_with_held_replies(stack, stop, start=False)  # still in the walking fsm
        lines = len(stack.node.lines)
        t_request = time.monotonic()
        assert _unanswered_moves(stack, t_request) > 0
        reply = stack.estop()
        t_estop = time.monotonic() - t_request
        assert reply.success, reply.message
        assert _unanswered_moves(stack, t_request + t_estop, received_by=t_request) > 0, "the e-stop waited for a Move"
        assert "longer than the forward wait" not in reply.message, reply.message
        assert wait_until(lambda: "HIGH_LEVEL -> EMERGENCY" in "".join(stack.node.lines[lines:]), 5.0)
        estop_s = _logged_duration_s(stack, "HIGH_LEVEL", "EMERGENCY", lines)
        damps = [e for e in requests(stack.record.events(since=t_request)) if is_damp(e)]
        assert len(damps) >= 2, damps  # the DampNoReply, then the sequence's Damp that it verified
        verified_after_s = damps[1]["t"] - damps[0]["t"]
        assert _unanswered_moves(stack, damps[1]["t"]) > 0, "no Move was unanswered at the verified Damp"
    finally:
        stop.set()
        if driver is not None:
            driver.join(5.0)  # before the fixture destroys the publisher it drives with
    print(f"Move replies held {HELD_S} s: set_mode idle {idle_s * 1000:.0f} ms (node), {t_idle * 1000:.0f} ms "
          f"(client); e-stop {estop_s * 1000:.0f} ms (node), {t_estop * 1000:.0f} ms (client); verified Damp "
          f"{verified_after_s * 1000:.1f} ms after the DampNoReply (robot's record)")
    check_latency("set_mode idle with a Move's reply held (node)", 0.0, idle_s, HELD_MOVE_ANSWER_S)
    check_latency("e-stop with a Move's reply held (node)", 0.0, estop_s, HELD_MOVE_ANSWER_S)
    check_latency("verified Damp after the DampNoReply (record)", 0.0, verified_after_s, HELD_MOVE_ANSWER_S)
