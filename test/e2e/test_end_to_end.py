"""The real mode_manager node against the real sim bridge over real DDS (loopback, unique domains)."""

from __future__ import annotations

import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest
from g1_mode_manager_msgs.msg import JointCommand, Mode
from geometry_msgs.msg import Twist
from sensor_msgs.msg import JointState

from g1_mode_manager.protocol import api_ids
from g1_mode_manager.topic_qos import MODE_QOS
from support.mode_manager import wait_until
from support.sim_record import is_damp, requests, velocity_of
from support.timing import QUIET_WINDOW_S, RECORD_WAIT_S, STEP_HELD_S, WATCHDOG_STOP_S

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

SPORT, SWITCHER = api_ids.LOCO_SERVICE, api_ids.MOTION_SWITCHER_SERVICE


def _start_walking(stack) -> None:
    r = stack.set_mode("high_level")
    assert r.success, r.message
    r = stack.loco("start")
    assert r.success, r.message
    assert wait_until(lambda: stack.sim.get()["sport"]["fsm_id"] == 500, 5.0)


def test_walks_on_cmd_vel_and_watchdog_stops_it(shared_stack_factory) -> None:
    stack = shared_stack_factory()
    _start_walking(stack)  # the robot shows fsm 500: the walk is measured from here, its start's steps included
    before = stack.sim.get()
    x0, y0, _ = before["base"]["position"]
    stack.drive(0.5, 4.0)
    last_cmd = time.monotonic()
    after = stack.sim.get()
    x1, y1, z1 = after["base"]["position"]
    walked = math.hypot(x1 - x0, y1 - y0)
    sim_s = after["sim_time"] - before["sim_time"]  # a loaded machine runs the sim below real time
    # at rest once the commands stop: how long the robot takes to stop is the sim's, in its own time, which a loaded
    # machine slows against the wall clock; the node's part is the StopMove below
    stopped = wait_until(lambda: stack.horizontal_speed() < 0.1, RECORD_WAIT_S, period_s=0.01)
    stop_after = time.monotonic() - last_cmd
    print(f"cmd_vel 0.5 m/s for 4 s ({sim_s:.2f} s of sim time): walked {walked:.2f} m; stopped {stop_after:.2f} s "
          "after the last cmd_vel")
    assert walked >= 0.3 * sim_s and z1 > 0.6  # 0.5 m/s after the limiter's ramp and the first steps
    assert stopped, "the robot did not come to rest after the cmd_vel stopped"
    assert stack.requests(SPORT, api_ids.LOCO_SET_VELOCITY) > 30  # the ramp at 20 Hz, then the 10 Hz keep-alive
    # the watchdog's own StopMove, on the robot's record (the robot would also stop when its 1 s Move lease
    # ran out: that alone proves nothing about the watchdog), and no Move after it
    moves = requests(stack.record.events(since=last_cmd), api_ids.LOCO_SET_VELOCITY)
    stops = [e["t"] - last_cmd for e in moves if velocity_of(e) == [0.0, 0.0, 0.0]]
    assert stops and stops[0] <= WATCHDOG_STOP_S, f"no StopMove within the watchdog timeout: {stops}"
    assert all(velocity_of(e) == [0.0, 0.0, 0.0] for e in moves if e["t"] - last_cmd >= stops[0]), \
        "a Move reached the robot after the watchdog's StopMove"


def test_cmd_vel_does_not_reach_the_robot_in_idle_or_low_level(shared_stack_factory) -> None:
    stack = shared_stack_factory()
    assert stack.set_mode("idle").success
    moves = stack.requests(SPORT, api_ids.LOCO_SET_VELOCITY)
    x0, y0, _ = stack.position()
    # each window: a node that forwarded cmd_vel would send ~10 Moves (ramp at 20 Hz, keep-alive at 10 Hz) in it,
    # and the count below must not move at all
    stack.drive(0.5, QUIET_WINDOW_S)
    x1, y1, _ = stack.position()
    assert math.hypot(x1 - x0, y1 - y0) < 0.05
    assert stack.set_mode("low_level").success
    stack.drive(0.5, QUIET_WINDOW_S)
    assert stack.requests(SPORT, api_ids.LOCO_SET_VELOCITY) == moves


def test_estop_from_low_level_reselects_the_service_then_damps(shared_stack_factory) -> None:
    stack = shared_stack_factory()
    r = stack.set_mode("low_level")
    assert r.success, r.message
    status = stack.sim.get()["sport"]
    assert not status["active"] and status["mode"] == ""
    selects = stack.requests(SWITCHER, api_ids.MS_SELECT_MODE)
    r = stack.estop()
    assert r.success, r.message
    status = stack.sim.get()["sport"]
    assert status["active"] and status["fsm_id"] == 1  # damped: only possible after the re-select
    assert stack.requests(SWITCHER, api_ids.MS_SELECT_MODE) == selects + 1


def test_estop_during_a_held_select_mode_reaches_damp_fast(shared_stack_factory) -> None:
    # hung in the gantry, as for any low-level work: a limp robot falling in LOW_LEVEL trips a body check (FAULT)
    # before the mode change below on a loaded machine. Every SelectMode is held STEP_HELD_S (2 s): an e-stop that
    # waited for the transition's would reach the robot about that long after its request, twice the bound below.
    stack = shared_stack_factory(faults={"delay_s": {str(api_ids.MS_SELECT_MODE): STEP_HELD_S}},
                                 bridge_args=("--gantry",))
    assert stack.set_mode("low_level").success
    selects = stack.requests(SWITCHER, api_ids.MS_SELECT_MODE)
    with ThreadPoolExecutor(1) as pool:
        pending = pool.submit(stack.set_mode, "high_level")
        assert wait_until(lambda: stack.requests(SWITCHER, api_ids.MS_SELECT_MODE) > selects, 5.0, period_s=0.005)
        damps = stack.requests(SPORT, api_ids.LOCO_SET_FSM_ID)
        estop_result: list = []
        t0 = time.monotonic()
        threading.Thread(target=lambda: estop_result.append(stack.estop()), daemon=True).start()
        reached = wait_until(lambda: stack.requests(SPORT, api_ids.LOCO_SET_FSM_ID) > damps, 2.0, period_s=0.002)
        mode_reply = pending.result(30.0)
    assert wait_until(lambda: bool(estop_result), 30.0)
    # the robot's record: when the first Damp arrived, against the SelectMode the sim holds for 2 s (an e-stop
    # that waited for it would come seconds late; the figure itself is the bench's business)
    first_damp = next(e["t"] for e in requests(stack.record.events(since=t0)) if is_damp(e))
    latency = first_damp - t0
    print(f"e-stop during a {STEP_HELD_S:.0f} s SelectMode: first Damp received by the robot {latency * 1000:.1f} ms after the "
          f"request; e-stop finished: {estop_result[0].message}")
    assert reached and latency < 1.0
    assert mode_reply.mode == Mode.EMERGENCY
    assert estop_result[0].success, estop_result[0].message
    assert stack.sim.get()["sport"]["fsm_id"] == 1


def test_emergency_is_final_and_a_late_subscriber_sees_it(shared_stack_factory) -> None:
    stack = shared_stack_factory()
    assert stack.set_mode("high_level").success
    assert stack.estop().success
    for name in ("idle", "high_level", "low_level"):
        r = stack.set_mode(name)
        assert not r.success and r.mode == Mode.EMERGENCY and "EMERGENCY" in r.message
    got: list[Mode] = []
    stack.ros.node.create_subscription(Mode, "/g1_mode_manager/mode", got.append, MODE_QOS)
    assert wait_until(lambda: bool(got), 10.0)
    assert got[0].name == "EMERGENCY" and got[0].damp_confirmed


def test_bad_input_gets_errors_node_stays_up_and_nothing_moves(shared_stack_factory) -> None:
    stack = shared_stack_factory()
    _start_walking(stack)
    x0, y0, _ = stack.position()
    pub = stack.cmd_vel_publisher()
    for bad in (math.nan, math.inf, -math.inf):
        msg = Twist()
        msg.linear.x, msg.angular.z = bad, bad
        for _ in range(20):
            pub.publish(msg)
            time.sleep(0.05)
    x1, y1, _ = stack.position()
    assert math.hypot(x1 - x0, y1 - y0) < 0.15  # non-finite commands became zero
    for name in ("warp", "UNINITIALIZED", "", "high level please"):
        r = stack.set_mode(name)
        assert not r.success and r.message
    from g1_mode_manager_msgs.srv import SetMode

    r = stack.ros.call(SetMode, "/g1_mode_manager/set_mode", SetMode.Request(mode=99))
    assert not r.success and "unknown mode number 99" in r.message
    arm = stack.ros.node.create_publisher(JointState, "/g1_mode_manager/arm_cmd", 10)
    low = stack.ros.node.create_publisher(JointCommand, "/g1_mode_manager/lowcmd", 10)
    assert wait_until(lambda: arm.get_subscription_count() > 0 and low.get_subscription_count() > 0, 10.0)
    arm.publish(JointState(name=["left_knee_joint"], position=[1.0]))
    arm.publish(JointState(name=["left_elbow_joint"], position=[1.0, 2.0]))
    low.publish(JointCommand(name=["left_knee_joint"], q=[1.0], kp=[100.0], kd=[1.0, 2.0]))
    low.publish(JointCommand(name=["left_knee_joint"], q=[1.0], kp=[100.0], kd=[1.0]))  # valid, wrong mode
    assert wait_until(lambda: all(text in stack.node.output() for text in (
        "arm_cmd rejected", "lowcmd rejected", "lowcmd dropped: mode is HIGH_LEVEL")), 5.0)
    assert sum(stack.frames("arm_sdk").values()) == 0 and sum(stack.frames("lowcmd").values()) == 0  # none reached it
    with ThreadPoolExecutor(8) as pool:
        results = list(pool.map(stack.set_mode, ["bogus", "idle", "high_level", "low_level", "x"] * 8))
    assert all(r.message for r in results)
    assert stack.node.alive()
    r = stack.set_mode("idle")
    assert r.message and stack.node.alive()


def _joint_reader(stack):
    latest: dict[str, JointState] = {}
    stack.ros.node.create_subscription(JointState, "/joint_states", lambda m: latest.__setitem__("m", m), 10)

    def q(name: str) -> float | None:
        msg = latest.get("m")
        return None if msg is None else msg.position[list(msg.name).index(name)]

    return q


def _publish_until(publish, reached, period_s: float, min_s: float, max_s: float) -> bool:
    """Publish every ``period_s`` for at least ``min_s`` and until ``reached()`` (looked at after ``min_s``, with
    the publishing going on) or ``max_s``: a loaded machine runs the sim below real time, and the joint follows
    the sim's time. Whether it was reached."""
    start = time.monotonic()
    while True:
        publish()
        elapsed = time.monotonic() - start
        if elapsed >= min_s and (reached() or elapsed >= max_s):
            return reached()
        time.sleep(period_s)


def test_arm_cmd_moves_a_shoulder_through_arm_sdk_and_hands_it_back(shared_stack_factory) -> None:
    """Also the path of rt/lowstate on demand: in a settled HIGH_LEVEL the robot sees the node's reader go
    (nothing needs the 500 Hz stream), and the first arm command brings it back for the ramp's start pose."""
    stack = shared_stack_factory()

    def node_readers() -> int:  # the robot's own count of who receives its rt/lowstate, less those before
        return stack.sim.get()["readers"]["lowstate"] - others

    others = stack.sim.get()["readers"]["lowstate"]
    assert stack.set_mode("high_level").success
    assert node_readers() == 1
    q = _joint_reader(stack)
    assert wait_until(lambda: q("left_shoulder_pitch_joint") is not None, 10.0)
    rest = q("left_shoulder_pitch_joint")
    target = -1.0
    arm = stack.ros.node.create_publisher(JointState, "/g1_mode_manager/arm_cmd", 10)
    assert wait_until(lambda: arm.get_subscription_count() > 0, 10.0)
    assert wait_until(lambda: node_readers() == 0, 6.0, period_s=0.1), "rt/lowstate still received by the idle node"
    command = JointState(name=["left_shoulder_pitch_joint"], position=[target])
    # at least the 2 s ramp (the weight at 1: the shoulder is the node's), then until the shoulder is there,
    # longer while a loaded sim has not followed yet
    at_target = _publish_until(lambda: arm.publish(command), lambda: abs(q("left_shoulder_pitch_joint") - target) < 0.15,
                               0.05, 2.0, 12.0)
    assert node_readers() == 1, "the arm commands did not subscribe rt/lowstate again"
    reached = q("left_shoulder_pitch_joint")
    assert at_target, f"shoulder at {reached:.3f}, target {target}"
    # silence: the weight ramps back to 0 and the controller takes the arm back
    assert wait_until(lambda: abs(q("left_shoulder_pitch_joint") - rest) < 0.15, 6.0)
    frames = stack.frames("arm_sdk")
    print(f"arm_sdk: shoulder {rest:.2f} -> {reached:.2f} rad (target {target}); frames {frames}")
    assert frames.get("accepted", 0) > 100 and frames.get("bad_crc", 0) == 0


def test_lowcmd_moves_a_joint_in_low_level_only(shared_stack_factory) -> None:
    stack = shared_stack_factory(bridge_args=("--gantry",))  # hung, as people do for low-level work
    q = _joint_reader(stack)
    low = stack.ros.node.create_publisher(JointCommand, "/g1_mode_manager/lowcmd", 10)
    assert wait_until(lambda: low.get_subscription_count() > 0 and q("left_elbow_joint") is not None, 10.0)
    assert stack.set_mode("low_level").success
    time.sleep(1.0)  # the limp robot settles in the gantry
    command = JointCommand(name=["left_elbow_joint"], q=[1.2], dq=[0.0], tau=[0.0], kp=[40.0], kd=[1.0])
    reached = _publish_until(lambda: low.publish(command), lambda: abs(q("left_elbow_joint") - 1.2) < 0.15,
                             0.01, 2.0, 10.0)
    elbow = q("left_elbow_joint")
    frames = stack.frames("lowcmd")
    print(f"lowcmd: elbow at {elbow:.2f} rad (target 1.2); frames {frames}")
    assert reached, f"elbow at {elbow:.2f} rad, target 1.2"
    assert frames.get("accepted", 0) > 50 and frames.get("bad_crc", 0) == 0 and frames.get("bad_mode_machine", 0) == 0


def test_losing_the_robot_link_is_an_error_and_stops_forwarding(shared_stack_factory) -> None:
    from diagnostic_msgs.msg import DiagnosticArray

    ok_level, error_level = 0, 2  # DiagnosticStatus.OK / ERROR (bytes constants in rclpy)

    stack = shared_stack_factory()
    _start_walking(stack)
    link_levels: list[tuple[int, str]] = []

    def on_diag(msg: DiagnosticArray) -> None:
        link_levels.extend((ord(s.level) if isinstance(s.level, bytes) else s.level, s.message)
                           for s in msg.status if s.name.endswith("robot link"))

    stack.ros.node.create_subscription(DiagnosticArray, "/diagnostics", on_diag, 10)
    stack.drive(0.3, 1.0)
    stack.set_faults({"pause_state": True})  # the robot stops publishing rt/lowstate, rt/sportmodestate
    moves = stack.requests(SPORT, api_ids.LOCO_SET_VELOCITY)
    stack.drive(0.3, 2.0)
    after = stack.requests(SPORT, api_ids.LOCO_SET_VELOCITY)
    assert after - moves <= 12, f"{after - moves} Moves sent without a link"  # at most the link timeout's worth
    assert wait_until(lambda: any(level == error_level for level, _ in link_levels), 5.0), link_levels
    assert any("robot link lost" in text for _, text in link_levels)
    stack.set_faults({})
    assert wait_until(lambda: link_levels and link_levels[-1][0] == ok_level, 5.0)
    resumed = stack.requests(SPORT, api_ids.LOCO_SET_VELOCITY)
    # forwarding resumes with the link: driving until the robot receives a Move again
    assert _drive_until(stack, 0.3, lambda: stack.requests(SPORT, api_ids.LOCO_SET_VELOCITY) > resumed, RECORD_WAIT_S)


def _drive_until(stack, vx: float, done, timeout_s: float) -> bool:
    """Drive in short spells, at least one, until ``done()`` or ``timeout_s``; whether it was done."""
    deadline = time.monotonic() + timeout_s
    while True:
        stack.drive(vx, 0.1)
        if done():
            return True
        if time.monotonic() > deadline:
            return False


def test_estop_retries_damps_the_robot_failed_within_the_same_request(shared_stack_factory) -> None:
    # The robot fails the next three Damps: the e-stop's immediate no-reply Damp and the next two; the
    # same e-stop request keeps trying until the robot shows damping.
    stack = shared_stack_factory(faults={"damp_fails": 3})
    assert stack.set_mode("high_level").success
    damps = stack.requests(SPORT, api_ids.LOCO_SET_FSM_ID)
    r = stack.estop()
    assert r.success, r.message
    status = stack.sim.get()
    assert status["sport"]["fsm_id"] == 1 and status["damp_fails_left"] == 0
    assert stack.requests(SPORT, api_ids.LOCO_SET_FSM_ID) - damps >= 4
    assert "retrying: SetFsmId failed: 3104" in r.message
