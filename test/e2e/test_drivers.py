"""Who drives, judged on the robot's record: a scripted planner publishing the autonomy's input at 20 Hz (as
Nav2's controller does) beside a teleop on cmd_vel. The two are told apart on the record by their commands:
the planner walks forward (vx only), the teleop turns (wz only).
"""

from __future__ import annotations

import subprocess
import threading
import time
from itertools import pairwise
from typing import Any

import pytest
from g1_mode_manager_msgs.msg import Mode
from std_srvs.srv import Trigger

from g1_mode_manager.protocol import api_ids
from g1_mode_manager.topic_qos import MODE_QOS
from support.mode_manager import wait_until
from support.planner import launch_planner, planner_subscribed
from support.processes import ManagedProcess, python_module
from support.sim_record import confirming_damp, requests, velocity_of
from support.timing import (
    KEEP_ALIVE_P95_S,
    ONE_RPC_S,
    QUIET_WINDOW_S,
    RECORD_WAIT_S,
    TAKEOVER_VISIBLE_S,
    check_latency,
)

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

AUTONOMY_MAX_VX = 0.35
AUTONOMY_TIMEOUT_S = 0.5
PARAMS = (f"autonomy_max_vx:={AUTONOMY_MAX_VX}", f"autonomy_timeout_s:={AUTONOMY_TIMEOUT_S}")
PLANNER_VX = 0.6  # over the autonomy's limit: the record shows the clamp
NAV_TOPIC = "/cmd_vel_nav"  # the autonomy's input of a shared stack's node (at the root namespace)
TELEOP_WZ = -0.6


class ModeLog:
    """Every ~/mode message with the monotonic time it reached the test's subscriber."""

    def __init__(self, stack) -> None:
        self.seen: list[tuple[float, Mode]] = []
        stack.ros.node.create_subscription(Mode, stack.name("mode"),
                                           lambda m: self.seen.append((time.monotonic(), m)), MODE_QOS)

    def first(self, since: float, predicate) -> tuple[float, Mode] | None:
        return next(((t, m) for t, m in list(self.seen) if t >= since and predicate(m)), None)

    def wait(self, since: float, predicate, timeout_s: float = RECORD_WAIT_S) -> tuple[float, Mode]:
        assert wait_until(lambda: self.first(since, predicate) is not None, timeout_s), \
            [m for _, m in self.seen[-3:]]
        found = self.first(since, predicate)
        assert found is not None
        return found


def _trigger(stack, name: str) -> Trigger.Response:
    return stack.ros.call(Trigger, stack.name(name), Trigger.Request())


def _moves(stack, since: float) -> list[tuple[float, list[float]]]:
    """(receive time, [vx, vy, wz]) of every Move (SetVelocity) the robot received since ``since``."""
    return [(e["t"], velocity_of(e)) for e in requests(stack.record.events(since), api_ids.LOCO_SET_VELOCITY)]


def _planner_moves(stack, since: float) -> list[tuple[float, list[float]]]:
    return [(t, v) for t, v in _moves(stack, since) if v[0] != 0.0]


def _led_since(stack, t0: float) -> list[list[int]]:
    """The colours the robot's head LED took since ``t0`` (the sim keeps each change with its receive time)."""
    return [c["rgb"] for c in stack.sim.get()["voice"]["led_changes"] if c["t"] >= t0]


def _cyan(rgb) -> bool:
    r, g, b = rgb
    return r == 0 and g == b and g > 0


def _walking(stack) -> None:
    assert stack.set_mode("high_level").success
    assert stack.loco("start").success


def _stack_and_planner(shared_stack_factory, vx: float, node_params: tuple[str, ...]) -> tuple[Any, ManagedProcess]:
    """A stack on the file's bridge and a planner publishing ``vx``, launched before the stack's node: a process
    that is up when the node starts is discovered with the node's start, one started after it waited 2-3 s here
    to be discovered. Not handed the robot, what it publishes meanwhile moves nothing."""
    planner = launch_planner(NAV_TOPIC, vx)
    try:
        stack = shared_stack_factory(node_params=node_params)
        assert f"{stack.ns}/cmd_vel_nav" == NAV_TOPIC, stack.ns
    except BaseException:
        planner.stop()
        raise
    return stack, planner


def _autonomy_driving(stack, planner: ManagedProcess) -> float:
    """Walking, the planner (publishing 0.3 m/s) handed the robot, its Moves on the record; the hand-over's time.
    Stops the planner if it fails."""
    try:
        _walking(stack)
        planner_subscribed(planner)
        t_hand = time.monotonic()
        assert _trigger(stack, "hand_over_to_autonomy").success
        assert wait_until(lambda: len(_planner_moves(stack, t_hand)) >= 5, RECORD_WAIT_S)
    except BaseException:
        planner.stop()
        raise
    return t_hand


def _teleop(stack, wz: float, seconds: float) -> float:
    """Publish the teleop's turn at 20 Hz for ``seconds``; returns the time just before its first message."""
    pub = stack.cmd_vel_publisher()
    from geometry_msgs.msg import Twist

    msg = Twist()
    msg.angular.z = wz
    t0 = time.monotonic()
    while time.monotonic() < t0 + seconds:
        pub.publish(msg)
        time.sleep(0.05)
    return t0


def test_the_planner_drives_only_once_handed_the_robot_within_its_limits_and_the_human_takes_over(
        shared_stack_factory) -> None:
    stack, planner = _stack_and_planner(shared_stack_factory, PLANNER_VX, PARAMS)
    try:
        modes = ModeLog(stack)
        # whatever the planner published while the node started and the robot started walking moved nothing
        # either (the record's view begins with the sim's reset), and the window below begins once it publishes
        _walking(stack)
        planner_subscribed(planner)
        t0 = time.monotonic()
        time.sleep(QUIET_WINDOW_S)
        assert _moves(stack, t0) == [], "a Move reached the robot before the autonomy was handed it"
        assert _planner_moves(stack, float("-inf")) == [], "a planner's Move reached the robot while it started"
        assert modes.wait(t0, lambda m: m.mode == Mode.HIGH_LEVEL)[1].driver == "teleop"

        t_hand = time.monotonic()
        r = _trigger(stack, "hand_over_to_autonomy")
        assert r.success, r.message
        modes.wait(t_hand, lambda m: m.driver == "autonomy")
        assert wait_until(lambda: len(_planner_moves(stack, t_hand)) >= 15, RECORD_WAIT_S)
        autonomy = _moves(stack, t_hand)
        assert all(0.0 < v[0] <= AUTONOMY_MAX_VX and v[1:] == [0.0, 0.0] for _, v in autonomy), autonomy
        assert max(v[0] for _, v in autonomy) == pytest.approx(AUTONOMY_MAX_VX)  # clamped to its limit

        # the human turns: the first non-zero teleop command takes over
        result: list[float] = []
        # half a second of turns (10 at 20 Hz): the takeover is the first of them, and the ones after it show the
        # teleop's Moves on the robot; the record is waited for, not read after a longer turn
        teleop = threading.Thread(target=lambda: result.append(_teleop(stack, TELEOP_WZ, 0.5)), daemon=True)
        teleop.start()
        teleop.join(10.0)
        t_teleop = result[0]
        t_seen, _ = modes.wait(t_teleop, lambda m: m.driver == "teleop")
        check_latency("takeover on ~/mode", t_teleop, t_seen, TAKEOVER_VISIBLE_S)
        assert wait_until(lambda: any(v[2] != 0.0 for _, v in _moves(stack, t_teleop)), RECORD_WAIT_S), \
            "no teleop Move on the robot"
        moves = _moves(stack, t_hand)
        first_teleop = next(t for t, v in moves if v[2] != 0.0)
        after = [(t, v) for t, v in moves if t >= first_teleop]
        assert all(v[0] == 0.0 for _, v in after), f"an autonomy Move after the teleop's first: {after[:5]}"
        last_autonomy = max(t for t, v in moves if v[0] != 0.0)
        print(f"takeover: teleop's first command -> last autonomy Move {1000 * (last_autonomy - t_teleop):.1f} ms, "
              f"first teleop Move {1000 * (first_teleop - t_teleop):.1f} ms (the robot's record)")

        # the planner goes on publishing: it does not get the robot back by itself
        t_quiet = time.monotonic()
        time.sleep(QUIET_WINDOW_S)
        assert _planner_moves(stack, t_quiet) == []
        assert modes.seen[-1][1].driver == "teleop"

        t_again = time.monotonic()  # handed over again, by the operator's CLI this time
        g1ctl = subprocess.run(python_module("g1_mode_manager.cli.main", "hand-over"), capture_output=True, text=True,
                               timeout=60)
        assert g1ctl.returncode == 0 and "the autonomy drives" in g1ctl.stdout, g1ctl.stdout + g1ctl.stderr
        assert wait_until(lambda: len(_planner_moves(stack, t_again)) >= 3, RECORD_WAIT_S)

        # the planner goes silent: the robot is stopped, the autonomy keeps the robot
        t_kill = time.monotonic()
        planner.stop()
        assert wait_until(lambda: any(v == [0.0, 0.0, 0.0] for _, v in _moves(stack, t_kill)), RECORD_WAIT_S)
        t_stop = next(t for t, v in _moves(stack, t_kill) if v == [0.0, 0.0, 0.0])
        check_latency("autonomy silent -> StopMove on the robot", t_kill, t_stop, AUTONOMY_TIMEOUT_S + ONE_RPC_S)
        assert _planner_moves(stack, t_stop) == []
        _, silent = modes.wait(t_kill, lambda m: m.autonomy_suspended.startswith("silent"))
        assert silent.driver == "autonomy", silent
    finally:
        planner.stop()


def test_stale_odometry_suspends_the_autonomy_and_an_estop_ends_its_drive(shared_stack_factory) -> None:
    stack, planner = _stack_and_planner(shared_stack_factory, 0.3, PARAMS)
    modes = ModeLog(stack)
    t_hand = _autonomy_driving(stack, planner)
    try:
        # the head LED on the robot: the autonomy's cyan pulse (1.5 s) instead of HIGH_LEVEL's green
        assert wait_until(lambda: any(_cyan(c) for c in _led_since(stack, t_hand)), RECORD_WAIT_S), \
            _led_since(stack, t_hand)
        t_cyan = next(c["t"] for c in stack.sim.get()["voice"]["led_changes"] if c["t"] >= t_hand and _cyan(c["rgb"]))
        time.sleep(1.6)
        shown = {tuple(c) for c in _led_since(stack, t_cyan)}
        assert len(shown) >= 3 and all(_cyan(c) for c in shown), shown  # a pulse, and nothing but cyan

        t_freeze = time.monotonic()
        stack.set_faults({"freeze_odom": True})  # the robot's state estimator stalls; everything else goes on
        _, suspended = modes.wait(t_freeze, lambda m: "odometry" in m.autonomy_suspended)
        assert suspended.driver == "autonomy" and suspended.link_ok, suspended
        assert wait_until(lambda: any(v == [0.0, 0.0, 0.0] for _, v in _moves(stack, t_freeze)), RECORD_WAIT_S)
        t_stop = next(t for t, v in _moves(stack, t_freeze) if v == [0.0, 0.0, 0.0])
        time.sleep(QUIET_WINDOW_S)
        assert _planner_moves(stack, t_stop) == [], "a Move of the suspended autonomy reached the robot"
        print(f"odometry frozen -> StopMove on the robot {1000 * (t_stop - t_freeze):.0f} ms "
              f"(autonomy_odom_timeout_s 0.5)")

        t_thaw = time.monotonic()
        stack.set_faults({})
        assert wait_until(lambda: len(_planner_moves(stack, t_thaw)) >= 3, RECORD_WAIT_S), "did not resume"
        modes.wait(t_thaw, lambda m: m.driver == "autonomy" and m.autonomy_suspended == "")

        t_estop = time.monotonic()
        r = stack.estop()
        assert r.success, r.message
        # a planner Move written just before the e-stop closed the gate may land after its DampNoReply (and be
        # refused by the damped robot); none after the sequence's Damp. (A StopMove may follow: the relay stops
        # what may still run; it moves nothing.)
        t_damp = confirming_damp(stack.record.events(t_estop))["t"]
        assert [(t, v) for t, v in _moves(stack, t_estop) if t > t_damp and any(v)] == []
        assert stack.sim.get()["sport"]["fsm_id"] == 1  # damped, on the robot
        modes.wait(t_estop, lambda m: m.mode == Mode.EMERGENCY and m.driver == "nobody")
    finally:
        planner.stop()


def test_a_warning_reaches_mode_when_it_happens_and_a_fall_while_the_autonomy_drives_is_a_fault(
        shared_stack_factory) -> None:
    # no heartbeat to speak of (one every 1000 s): what reaches ~/mode came because it changed
    stack, planner = _stack_and_planner(shared_stack_factory, 0.3, (*PARAMS, "mode_publish_rate_hz:=0.001"))
    modes = ModeLog(stack)
    _autonomy_driving(stack, planner)
    try:

        t_battery = time.monotonic()
        stack.set_faults({"battery_soc": 15})  # low: a warning, nothing held
        t_warned, _ = modes.wait(t_battery, lambda m: any(w.startswith("battery_low") for w in m.warnings))
        print(f"battery low on the robot -> ~/mode warning at the test's subscriber {t_warned - t_battery:.2f} s "
              f"(the check's debounce included)")

        t_push = time.monotonic()
        stack.set_faults({"push": {"force": 600, "direction": [1, 0], "duration": 0.3}})
        _, fault = modes.wait(t_push, lambda m: m.mode == Mode.FAULT and m.damp_confirmed)
        assert fault.driver == "nobody", fault
        t_damp = confirming_damp(stack.record.events(t_push))["t"]  # as for the e-stop of the stale-odometry test
        assert [(t, v) for t, v in _moves(stack, t_push) if t > t_damp and any(v)] == []
        assert stack.sim.get()["sport"]["fsm_id"] == 1

        # cleared and back in HIGH_LEVEL: the teleop drives; the planner, still publishing, needs a new hand-over
        stack.set_faults({})
        assert wait_until(lambda: stack.clear_fault().success, RECORD_WAIT_S, period_s=0.5)
        t_back = time.monotonic()
        assert stack.set_mode("high_level").success
        assert modes.wait(t_back, lambda m: m.mode == Mode.HIGH_LEVEL)[1].driver == "teleop"
        time.sleep(QUIET_WINDOW_S)
        assert _planner_moves(stack, t_back) == []
    finally:
        planner.stop()


@pytest.mark.latency_only
def test_a_steady_drive_keeps_its_move_alive_at_the_keep_alives_rate_on_the_record(shared_stack_factory) -> None:
    """cmd_vel_rate_hz (10): a teleop holding one command gets one Move every 100 ms on the robot, not one every
    other period."""
    stack = shared_stack_factory()
    assert stack.set_mode("high_level").success
    assert stack.loco("start").success
    t0 = time.monotonic()
    stack.drive_sim_time(0.3, 10.0)
    steady = [t for t, v in _moves(stack, t0) if v == [0.3, 0.0, 0.0]]  # past the ramp: keep-alives only
    gaps = sorted(b - a for a, b in pairwise(steady))
    assert len(gaps) >= 20, f"only {len(steady)} steady Moves on the record"
    p95 = gaps[round(0.95 * (len(gaps) - 1))]
    print(f"keep-alive over a steady drive: {len(steady)} Moves, median interval {1000 * gaps[len(gaps) // 2]:.1f} ms")
    check_latency("keep-alive interval p95", 0.0, p95, KEEP_ALIVE_P95_S)
