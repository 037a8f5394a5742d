"""Command streams that can never leave the robot unsafe, judged by what the sim received (its record).

The real node against the real sim bridge, which records every request, frame and state change with
CLOCK_MONOTONIC receive times (``--record``). Every decisive assertion reads that record.
"""

from __future__ import annotations

import itertools
import math
import os
import pty
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest
from g1_mode_manager_msgs.msg import JointCommand
from geometry_msgs.msg import Twist
from sensor_msgs.msg import JointState

from g1_mode_manager.protocol import api_ids
from support.mode_manager import start_mode_manager, wait_until
from support.processes import ManagedProcess
from support.sim_record import SimRecord, states, velocity_of
from support.timing import QUIET_WINDOW_S, RECORD_WAIT_S

from .conftest import Stack

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

SET_VELOCITY = api_ids.LOCO_SET_VELOCITY
ARM_STEP = 0.02 / 2.0 + 1e-6  # arm_ramp_time_s 2 s at arm_rate_hz 50: the largest change of one frame
MOVE_STEP = 1.5 * 0.05 + 1e-6  # max_ax 1.5 m/s^2 over the 20 Hz tick: the largest change of one acknowledged Move


@pytest.fixture
def recorded(shared_stack_factory) -> Callable[..., tuple[Stack, SimRecord]]:
    """factory(*node_params) -> (stack, the sim's record)."""

    def factory(*params: str, gantry: bool = False) -> tuple[Stack, SimRecord]:
        stack = shared_stack_factory(node_params=params, bridge_args=("--gantry",) if gantry else ())
        return stack, stack.record

    return factory


@contextmanager
def publishing(publish: Callable[[], None], rate_hz: float) -> Iterator[None]:
    """Call ``publish`` at ``rate_hz`` in a thread while the body runs."""
    stop = threading.Event()

    def run() -> None:
        while not stop.is_set():
            publish()
            stop.wait(1.0 / rate_hz)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(2.0)


def _publisher(stack: Stack, msg_type, topic: str):
    pub = stack.ros.node.create_publisher(msg_type, topic, 10)
    assert wait_until(lambda: pub.get_subscription_count() > 0, 10.0)
    return pub


def _twist(vx: float) -> Twist:
    msg = Twist()
    msg.linear.x = vx
    return msg


def _stall(proc: ManagedProcess, seconds: float) -> None:
    """Freeze the node process (a scheduling stall far beyond any tick period)."""
    os.kill(proc.proc.pid, signal.SIGSTOP)
    time.sleep(seconds)
    os.kill(proc.proc.pid, signal.SIGCONT)


def _settled(read: Callable[[], list], quiet_s: float = 0.5, timeout_s: float = 10.0) -> list:
    """``read()`` once it has stopped growing for ``quiet_s``: what a node sent just before it exited can
    still be on its way into the sim's record on a loaded machine."""
    seen, since = read(), time.monotonic()
    while time.monotonic() - since < quiet_s and time.monotonic() < since + timeout_s:
        time.sleep(0.05)
        now = read()
        if len(now) != len(seen):
            seen, since = now, time.monotonic()
    return seen


def _frames(record: SimRecord, topic: str, since: float = float("-inf")) -> list[dict]:
    return [e for e in record.events(since) if e["k"] == "frame" and e["topic"] == topic]


def _moves(record: SimRecord, kind: str = "req", since: float = float("-inf")) -> list[dict]:
    return [e for e in record.events(since) if e["k"] == kind and e.get("api") == SET_VELOCITY]


def _is_stop(event: dict) -> bool:
    return velocity_of(event) == [0.0, 0.0, 0.0]


def _start_walking(stack: Stack) -> None:
    r = stack.set_mode("high_level")
    assert r.success, r.message
    r = stack.loco("start")
    assert r.success, r.message
    assert wait_until(lambda: stack.sim.get()["sport"]["fsm_id"] == 500, 5.0)


# --- lowcmd ------------------------------------------------------------------------------------------
def test_leaving_low_level_leaves_the_robot_holding_a_damping_frame_for_idle_and_estop(recorded) -> None:
    stack, record = recorded()
    # a robot-like service switch: on a G1 SelectMode and ReleaseMode take seconds, so "damped before the
    # service came back" is decided by the robot's state, not by which of two topics' packets arrived first
    stack.set_faults({"delay_s": {str(api_ids.MS_SELECT_MODE): 0.3, str(api_ids.MS_RELEASE_MODE): 0.3}})
    low = _publisher(stack, JointCommand, "/g1_mode_manager/lowcmd")
    stiff = JointCommand(name=["left_knee_joint", "right_knee_joint"], q=[0.5, 0.5], kp=[100.0, 100.0],
                         kd=[2.0, 2.0])
    t_estop = 0.0
    for exit_to in ("idle", "estop"):
        assert stack.set_mode("low_level").success
        with publishing(lambda: low.publish(stiff), 200.0):  # a user stream that does not stop by itself
            assert wait_until(lambda: any(f["kp_max"] == 100.0 for f in _frames(record, "lowcmd")), 5.0)
            t_exit = t_estop = time.monotonic()
            r = stack.estop() if exit_to == "estop" else stack.set_mode("idle")
            t_reply = time.monotonic()
            assert r.success, r.message
            time.sleep(0.5)  # the stream goes on after the mode changed
        # when the gate closed, as the robot saw it: an e-stop registers right after its first (no-reply)
        # Damp, so its second Damp comes after; a transition closes the gate before it answers
        damps = [e["t"] for e in record.events(t_exit) if e["k"] == "req" and e.get("p") == '{"data": 1}']
        cut = damps[1] if exit_to == "estop" else t_reply
        received = [f for f in _frames(record, "lowcmd", t_exit) if f["ok"]]
        late = [f["kp_max"] for f in received if f["t"] > cut + 0.02 and f["kp_max"] > 0.0]
        assert late == [], f"{exit_to}: user frames after the gate closed: {late}"
        kps = [f["kp_max"] for f in received]
        assert kps[-1] == 0.0  # the frame the motor drivers hold is a damping one
        after = [f["kp_max"] for f in received if f["t"] > cut]
        print(f"{exit_to}: {len(kps) - len(after)} frames before the gate closed, {len(after)} damping frames after")
    # e-stop: the motor drivers held a damping frame (taken in debug mode) before the service came back
    events = record.events(t_estop)
    back = [e["t"] for e in states(events) if e["svc"]]
    damping = [f["t"] for f in _frames(record, "lowcmd", t_estop) if f["ok"] and f["kp_max"] == 0.0]
    assert back and damping, (back, damping)
    assert damping[0] < back[0], f"first damping frame {damping[0] - back[0]:+.4f} s after the service came back"


# --- arm_sdk ---------------------------------------------------------------------------------------
def _arm_publisher(stack: Stack) -> Callable[[], None]:
    arm = _publisher(stack, JointState, "/g1_mode_manager/arm_cmd")
    return lambda: arm.publish(JointState(name=["left_shoulder_pitch_joint"], position=[-1.0]))


def _weight_jumps(frames: list[dict]) -> list[tuple[float, float]]:
    ws = [f["w"] for f in frames]
    return [(a, b) for a, b in itertools.pairwise(ws) if abs(b - a) > ARM_STEP]


def _lies_still(stack: Stack) -> bool:
    status = stack.sim.get()
    return status["body"]["posture"] == "on_back" and math.hypot(*status["base"]["linear_velocity"]) < 0.1


def test_arm_weight_ramps_only_while_the_robot_stands_and_starts_from_zero(recorded) -> None:
    # What is judged here is the arm relay alone, so the body checks are off.
    stack, record = recorded("body_checks_enabled:=false")
    assert stack.set_mode("high_level").success
    assert stack.loco("damp").success  # the robot falls onto its back, damped: it ignores arm_sdk
    publish = _arm_publisher(stack)
    with publishing(publish, 20.0):
        # until the robot lies (lie_to_stand needs that): arm commands flow all along, and a node that ramped
        # while the robot ignored them would be well past one step by the first frame the robot takes, as the
        # lie-to-stand alone takes ~5.6 s (longer than the 2 s ramp)
        assert wait_until(lambda: _lies_still(stack), RECORD_WAIT_S), "the damped robot never lay still on its back"
        r = stack.loco("lie_to_stand")  # up from the floor: a stand_up would be refused, the robot lies
        assert r.success, r.message
        t_up = time.monotonic()
        # a quarter of the 2 s ramp taken by the standing robot (25 frames at 50 Hz): its start, step by step
        assert wait_until(lambda: sum(f["ok"] for f in _frames(record, "arm_sdk", t_up)) >= 25, RECORD_WAIT_S)
    taken = [f for f in _frames(record, "arm_sdk") if f["ok"]]
    print(f"first weights the standing robot took: {[round(f['w'], 3) for f in taken[:5]]}")
    assert taken[0]["w"] <= ARM_STEP, "the robot got a weight ramped while it ignored arm_sdk"
    assert not _weight_jumps(taken)


def test_arm_weight_never_jumps_freezes_on_link_loss_and_ramps_out_at_shutdown(recorded) -> None:
    stack, record = recorded()
    assert stack.set_mode("high_level").success
    publish = _arm_publisher(stack)
    with publishing(publish, 20.0):
        assert wait_until(lambda: any(f["w"] == 1.0 for f in _frames(record, "arm_sdk")), 6.0)
        stack.set_faults({"pause_state": True})  # the robot stops publishing its state
        t_lost = time.monotonic()
        # the link timeout is 0.5 s: 0.4 s of it lost past 0.6 s is 20 frames' time at 50 Hz, and a weight
        # that moved while unwatched shows in the first frame (a step of 0.01) or as a jump when the link is back
        time.sleep(1.0)
        t_back = time.monotonic()
        stack.set_faults({})
        time.sleep(0.3)  # the link is back (the robot's state at 500 Hz) before the node is stalled
        _stall(stack.node, 0.5)
        time.sleep(0.5)  # 25 frames' time after the stall: a jump on resuming is in its first frames
        t_stop = time.monotonic()
        stack.node.proc.send_signal(signal.SIGINT)  # shutdown while arm commands still arrive
        stack.node.proc.wait(15.0)
    frames = _settled(lambda: _frames(record, "arm_sdk"))
    during = [f for f in _frames(record, "arm_sdk", t_lost + 0.6) if f["t"] < t_back]  # the link timeout is 0.5 s
    print(f"{len(frames)} arm_sdk frames; during link loss: {sorted({f['w'] for f in during})}; "
          f"last weights {[round(f['w'], 3) for f in frames[-3:]]}")
    assert all(f["w"] == 1.0 for f in during), "the weight moved while the robot could not be watched"
    assert not _weight_jumps(frames), _weight_jumps(frames)
    assert frames[-1]["w"] == 0.0 and frames[-1]["t"] > t_stop  # the arms were handed back before exit
    assert stack.node.proc.returncode == 0


# --- cmd_vel ---------------------------------------------------------------------------------------
def test_move_ramp_counts_only_acknowledged_moves_and_shutdown_stops_the_robot(recorded) -> None:
    stack, record = recorded()
    assert stack.set_mode("high_level").success  # lock stand (fsm 4): the robot refuses Move
    pub = _publisher(stack, Twist, "/cmd_vel")
    t_refused = time.monotonic()
    with publishing(lambda: pub.publish(_twist(0.8)), 20.0):
        # three Moves the robot refused: a limiter that counted them would take its first acknowledged Move
        # three steps from standstill
        assert wait_until(lambda: len([e for e in _moves(record, "done", t_refused) if e["code"] != 0]) >= 3,
                          RECORD_WAIT_S), "the robot in the lock stand never refused a Move"
        r = stack.loco("start")
        assert r.success, r.message
        time.sleep(0.2)
        t_stall = time.monotonic()
        _stall(stack.node, 0.5)
        # the ramp goes on to 0.8 m/s after the stall: every step of it after the stall is on the record
        assert wait_until(lambda: any(e["code"] == 0 and abs(velocity_of(e)[0] - 0.8) < 1e-3
                                      for e in _moves(record, "done", t_stall)), RECORD_WAIT_S), \
            "the robot never took a Move at full speed after the stall"
        stack.node.proc.send_signal(signal.SIGINT)
        stack.node.proc.wait(15.0)
    received = _settled(lambda: _moves(record))
    done = [e for e in _moves(record, "done") if e["code"] == 0]
    vx = [velocity_of(e)[0] for e in done]
    print(f"acknowledged Moves: {[round(v, 3) for v in vx[:6]]} ... {[round(v, 3) for v in vx[-3:]]}")
    assert vx[0] <= MOVE_STEP, "the first Move the robot took was not one step from standstill"
    assert all(b - a <= MOVE_STEP for a, b in itertools.pairwise(vx)), vx
    assert _is_stop(received[-1]), "no StopMove at shutdown: the robot walks on"


def test_unanswered_moves_and_stop_moves_end_in_a_stop_move_the_robot_received(recorded) -> None:
    stack, record = recorded()
    _start_walking(stack)
    pub = _publisher(stack, Twist, "/cmd_vel")
    # A Move executed but answered too late (rpc_timeout_s 1 s): the relay must count it as moving.
    stack.set_faults({"delay_s": {str(SET_VELOCITY): 1.3}})
    with publishing(lambda: pub.publish(_twist(0.5)), 20.0):
        time.sleep(0.3)
    t_quiet = time.monotonic()
    assert wait_until(lambda: any(_is_stop(e) for e in _moves(record, since=t_quiet)), 6.0), \
        "a timed-out Move was never followed by a StopMove"
    stack.set_faults({})
    # every Move held 1.3 s (the StopMove too) has been answered: none lands in the part below
    assert wait_until(lambda: len(_moves(record, "done")) >= len(_moves(record)), RECORD_WAIT_S), \
        "Moves held by the robot were never answered"
    # A StopMove that is lost: sent again until the robot answers it.
    t_walk = time.monotonic()
    with publishing(lambda: pub.publish(_twist(0.5)), 20.0):
        # walking again: the robot acknowledged a Move (the watchdog then owes it a StopMove)
        assert wait_until(lambda: any(e["code"] == 0 and not _is_stop(e) for e in _moves(record, "done", t_walk)),
                          RECORD_WAIT_S), "the robot never took a Move again"
        stack.set_faults({"drop": [SET_VELOCITY]})
    t_drop = time.monotonic()
    # the watchdog's StopMove reached the robot and was dropped (never answered): what follows is a new one
    assert wait_until(lambda: any(_is_stop(e) for e in _moves(record, since=t_drop)), RECORD_WAIT_S), \
        "no StopMove after the commands stopped"
    t_back = time.monotonic()
    stack.set_faults({})
    assert wait_until(lambda: any(_is_stop(e) for e in _moves(record, "done", t_back)), 6.0), \
        "a lost StopMove was never sent again"


def test_move_duration_longer_than_two_seconds_is_refused(sdk_domain: int) -> None:
    # A continuous Move (864000 s) outlives the node: the robot would walk on after a crash.
    with pytest.raises(RuntimeError, match="move_duration_s"):
        node = start_mode_manager(sdk_domain, "move_duration_s:=1000000.0")
        node.stop()


def test_g1ctl_drive_stops_publishing_without_keys_and_sub_dead_band_is_not_sent(recorded) -> None:
    stack, record = recorded()
    _start_walking(stack)
    master, slave = pty.openpty()
    tool = subprocess.Popen([sys.executable, "-m", "g1_mode_manager.cli.main", "drive"], stdin=slave,
                            stdout=slave, stderr=slave, start_new_session=True)
    os.close(slave)
    output = bytearray()
    drained = threading.Thread(target=lambda: _drain(master, output), daemon=True)
    drained.start()
    try:
        # its status line comes after it put the terminal in cbreak mode (which discards keys typed before),
        # and its /cmd_vel publisher is in the graph (a loaded machine can take seconds for both); then a
        # margin for the mode manager's subscription to match it
        assert wait_until(lambda: b"\rvx " in bytes(output), 30.0), f"g1ctl never read keys: {bytes(output)!r}"
        assert wait_until(lambda: stack.ros.node.count_publishers("/cmd_vel") >= 1, 30.0), "g1ctl never published"
        # a held key, repeating, until the robot walks: the mode manager's subscription may match g1ctl's
        # publisher seconds after the publisher is in the graph on a loaded machine (keys published before
        # that are lost; the 1 s margin this test had was once not enough in a full run)
        t_first = time.monotonic()
        while not any(not _is_stop(e) for e in _moves(record, since=t_first)):
            assert time.monotonic() - t_first < 20.0, "held keys in g1ctl drive never moved the robot"
            os.write(master, b"w")
            time.sleep(0.05)
        t_key = time.monotonic()
        assert wait_until(lambda: any(_is_stop(e) for e in _moves(record, "done", t_key)), 4.0), \
            "the robot was never stopped: g1ctl drive keeps publishing with no key pressed"
        stop_at = next(e["t"] for e in _moves(record, "done", t_key) if _is_stop(e))
        assert tool.poll() is None  # the tool still runs: it simply went silent
        print(f"StopMove received {stop_at - t_key:.2f} s after the last key")
    finally:
        # Ctrl-C as a terminal delivers it, a SIGINT: this pty is not the tool's controlling terminal, so a \x03
        # written to it is taken by the line discipline (ISIG stays on in cbreak mode) and never reaches the
        # tool, which then ran on until the wait below killed it
        tool.send_signal(signal.SIGINT)
        try:
            tool.wait(10.0)
        except subprocess.TimeoutExpired:
            tool.kill()
            tool.wait(5.0)
        os.close(master)
    pub = _publisher(stack, Twist, "/cmd_vel")
    t_creep = time.monotonic()
    with publishing(lambda: pub.publish(_twist(0.05)), 20.0):  # below the robot's dead band
        # a node that sent them would send ~10 at its 10-20 Hz in this window, not at most one
        time.sleep(QUIET_WINDOW_S)
    sent = _moves(record, since=t_creep)
    assert len(sent) <= 1, f"{len(sent)} useless sub-threshold Moves"


def _drain(fd: int, into: bytearray) -> None:
    """Read a pty's output until it closes (so the tool never blocks on a full terminal)."""
    try:
        while chunk := os.read(fd, 4096):
            into.extend(chunk)
    except OSError:
        pass
