"""The arm_sdk relay against the fake robot port: the weight follows what the robot takes, never jumps."""

from __future__ import annotations

import itertools
import math
import threading
import time

import pytest
from relay_fakes import Gate

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from g1_mode_manager.protocol.motors import JOINT_INDEX
from g1_mode_manager.relay.arm import ArmRelay
from g1_mode_manager.relay.link_health import LinkHealth

PERIOD = 0.02
MAX_STEP = PERIOD / 1.0  # ramp 1 s at 50 Hz
ELBOW = JOINT_INDEX["left_elbow_joint"]


def _relay(port, gate, events) -> ArmRelay:
    return ArmRelay(port, gate, LinkHealth(port, gate, 0.5), events, ramp_time_s=1.0, silence_timeout_s=0.5,
                    kp=60.0, kd=1.5, period_s=PERIOD)


def _weights(port) -> list[float]:
    return [f.args[1] for f in port.stream("write_arm_sdk")]


def _drive(relay, n, target=1.0) -> None:
    for _ in range(n):
        relay.submit(["left_elbow_joint"], [target])
        relay.tick(PERIOD)


def _fsm(port, fsm_id: int, fsm_mode: int = FsmMode.STATIC) -> None:
    port.sport = SportState(fsm_id, fsm_mode, 0, 0.0, age_s=0.01)


def test_ramps_in_holds_unnamed_joints_and_ramps_out_on_leaving(events, logs) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events)
    _drive(relay, 60)
    frames = port.stream("write_arm_sdk")
    weights = _weights(port)
    assert weights[0] == pytest.approx(MAX_STEP) and weights[-1] == 1.0
    assert max(b - a for a, b in itertools.pairwise(weights)) <= MAX_STEP + 1e-9
    targets = frames[-1].args[0]
    assert targets[ELBOW - 12].q == 1.0
    shoulder = JOINT_INDEX["right_shoulder_pitch_joint"]
    assert targets[shoulder - 12].q == pytest.approx(port.positions[shoulder])
    gate.mode = Mode.IDLE
    for _ in range(60):
        relay.tick(PERIOD)
    out = _weights(port)[len(weights):]
    assert out[-1] == 0.0 and max(a - b for a, b in itertools.pairwise(out)) <= MAX_STEP + 1e-9
    n = len(port.stream("write_arm_sdk"))
    relay.tick(PERIOD)
    assert len(port.stream("write_arm_sdk")) == n  # nothing more once back at zero
    assert any("handed back" in text for _, text in logs)


def test_targets_start_at_the_measured_pose_and_blend_with_the_weight(events) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events)
    _drive(relay, 1, target=2.0)
    first = port.stream("write_arm_sdk")[0].args[0][ELBOW - 12].q
    measured = port.positions[ELBOW]
    assert first == pytest.approx(measured + MAX_STEP * (2.0 - measured))


def test_no_ramp_while_the_robot_does_not_take_arm_sdk_and_restart_from_zero(events) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events)
    _fsm(port, FsmId.DAMP)  # lying damped: the robot ignores arm_sdk
    _drive(relay, 100)
    assert _weights(port) == [] and relay.weight == 0.0
    _fsm(port, FsmId.STAND_UP, FsmMode.DYNAMIC)  # standing up, motion still running
    _drive(relay, 20)
    assert _weights(port) == []
    port.positions = [0.3] * 29  # the pose it stood up in
    _fsm(port, FsmId.STAND_UP)
    _drive(relay, 30)
    assert _weights(port)[0] == pytest.approx(MAX_STEP)
    assert port.stream("write_arm_sdk")[0].args[0][0].q == pytest.approx(0.3)  # waist held where it is now
    _fsm(port, FsmId.DAMP)  # damped mid-ramp: the robot dropped the blend itself
    _drive(relay, 5)
    _fsm(port, FsmId.START, FsmMode.DYNAMIC)  # walking takes arm_sdk again: from 0, not from 0.6
    n = len(_weights(port))
    _drive(relay, 1)
    assert _weights(port)[n:] == [pytest.approx(MAX_STEP)]


def test_a_scheduling_stall_changes_the_weight_by_one_nominal_step_at_most(events) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events)
    _drive(relay, 3)
    relay.submit(["left_elbow_joint"], [1.0])
    relay.tick(0.5)
    w = _weights(port)
    assert w[-1] - w[-2] == pytest.approx(MAX_STEP)


def test_link_loss_freezes_the_weight_and_resumes_from_the_last_one_sent(events, logs) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events)
    _drive(relay, 25)
    sent = _weights(port)[-1]
    port.lowstate_age = 5.0
    gate.mode = Mode.IDLE  # even leaving HIGH_LEVEL: nothing is sent, nothing pretends to ramp
    for _ in range(100):
        relay.tick(PERIOD)
    assert _weights(port)[-1] == sent and relay.weight == sent
    assert not any("handed back" in text for _, text in logs)
    port.lowstate_age = 0.01
    relay.tick(PERIOD)
    assert _weights(port)[-1] == pytest.approx(sent - MAX_STEP)


def test_a_closed_forward_gate_ramps_out_instead_of_in(events) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events)
    _drive(relay, 10)
    gate.forward_refuses = True  # an e-stop began between the check and the send
    _drive(relay, 1)
    w = _weights(port)
    assert w[-1] < w[-2]


def _ticking(relay, stop: threading.Event) -> threading.Thread:
    def run() -> None:
        while not stop.is_set():
            relay.tick(PERIOD)
            time.sleep(0.002)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def test_shutdown_ramps_out_before_returning(events) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events)
    _drive(relay, 60)
    stop = threading.Event()
    thread = _ticking(relay, stop)
    try:
        assert relay.ramp_out()
    finally:
        stop.set()
        thread.join()
    w = _weights(port)
    assert w[-1] == 0.0 and min(w[-50:]) == 0.0
    _drive(relay, 10)  # commands after shutdown began do not ramp in again
    assert _weights(port)[-1] == 0.0


def test_leaving_high_level_ramps_out_first_but_an_estop_never_waits(events) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events)
    gate.add_leave_listener(relay.on_leave)
    _drive(relay, 60)
    stop = threading.Event()
    thread = _ticking(relay, stop)
    try:
        gate.leave(Mode.LOW_LEVEL)  # returns only once weight 0 was sent
        assert _weights(port)[-1] == 0.0
        gate.mode = Mode.HIGH_LEVEL
        stop.set()
        thread.join()
        _drive(relay, 60)
        t0 = time.monotonic()
        gate.leave(Mode.EMERGENCY)
        assert time.monotonic() - t0 < 0.5 and relay.weight == 1.0
    finally:
        stop.set()


@pytest.mark.parametrize("bad", [(["left_knee_joint"], [0.1], "not allowed"), (["left_elbow_joint"], [0.1, 0.2],
                                 "entries"), (["left_elbow_joint"], [math.nan], "non-finite")])
def test_bad_input_refused_and_nothing_sent(events, bad) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.HIGH_LEVEL), events)
    names, positions, match = bad
    assert match in relay.submit(names, positions)
    relay.tick(PERIOD)
    assert port.stream("write_arm_sdk") == []


def test_outside_high_level_the_frames_gate_drops_the_commands_taken_with_the_mode_named(events, logs) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.LOW_LEVEL)
    relay = _relay(port, gate, events)
    assert relay.submit(["left_elbow_joint"], [0.1]) is None  # taken: the frame's gate decides
    assert relay.submit(["left_elbow_joint"], [0.2]) is None
    relay.tick(PERIOD)
    relay.tick(PERIOD)
    assert port.stream("write_arm_sdk") == [] and not relay.busy()  # dropped, and its stream forgotten
    assert events.counts()["arm_cmd_dropped"] == 2
    assert ("warn", "arm_cmd dropped: mode is LOW_LEVEL, arm commands pass only in HIGH_LEVEL") in logs
    gate.mode = Mode.HIGH_LEVEL
    relay.tick(PERIOD)
    assert port.stream("write_arm_sdk") == []  # nothing taken in LOW_LEVEL reaches the robot later


def test_after_an_estop_no_arm_frame_is_sent_even_while_the_robot_still_stands(events, logs) -> None:
    """The e-stop's Damp may take a moment to land (the robot still stands): no ramp-out, no frame at all."""
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events)
    _drive(relay, 30)
    assert _weights(port)[-1] > 0.2
    sent = len(_weights(port))
    gate.leave(Mode.EMERGENCY)  # the robot's fsm is still 4: it would still take arm_sdk
    for _ in range(20):
        relay.tick(PERIOD)
    assert _weights(port)[sent:] == []
