"""The simulated G1 moves like the robot: walks, turns, stops, sinks when damped, falls limp, stands up,
lends its arms to arm_sdk and obeys LowCmd in debug mode. Runs MuJoCo: run under the sim CPU lock."""

from __future__ import annotations

import math

import numpy as np
import pytest

from g1_mode_manager.protocol.api_ids import ERR_SERVER_API_NOT_IMPL, MOVE_CONTINUOUS_DURATION_S, OK
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from g1_mode_manager.protocol.motors import JOINT_INDEX, NUM_JOINTS
from g1_sim.firmware import SimG1
from g1_sim.firmware.state import quat_to_rpy
from g1_sim.tour import ARM_SDK_HOME, R_SHOULDER_PITCH, send_arm_sdk

pytestmark = pytest.mark.sim


def run(sim: SimG1, seconds: float) -> None:
    sim.step(round(seconds / sim.dt))


def yaw(sim: SimG1) -> float:
    return float(quat_to_rpy(sim.base_pose().quaternion)[2])


def mean_speed(sim: SimG1, seconds: float) -> float:
    """Average horizontal speed over the next ``seconds`` (the gait makes instantaneous speed wobble)."""
    p0 = sim.base_pose().position[:2]
    run(sim, seconds)
    return float(np.linalg.norm(sim.base_pose().position[:2] - p0) / seconds)


@pytest.fixture
def sim() -> SimG1:
    return SimG1()


@pytest.fixture
def walking(sim: SimG1) -> SimG1:
    """Walking forward at 0.5 m/s for 4 s."""
    assert sim.set_fsm_id(FsmId.START) == OK
    assert sim.set_velocity(0.5, 0.0, 0.0, MOVE_CONTINUOUS_DURATION_S) == OK
    run(sim, 4.0)
    return sim


def test_walks_forward(walking: SimG1) -> None:
    assert walking.base_pose().position[0] >= 1.2  # booted at x = 0, facing +x
    assert not walking.fallen
    assert walking.base_pose().position[2] > 0.65
    assert walking.get_fsm_mode() == (OK, FsmMode.DYNAMIC)


def test_stops_within_1_5_s(walking: SimG1) -> None:
    assert walking.set_velocity(0.0, 0.0, 0.0) == OK
    run(walking, 1.3)
    assert mean_speed(walking, 0.2) < 0.1
    assert walking.get_fsm_mode() == (OK, FsmMode.STATIC)
    assert walking.set_fsm_id(FsmId.STAND_UP) == OK  # static again: switching allowed


def test_turns(sim: SimG1) -> None:
    assert sim.set_fsm_id(FsmId.START) == OK
    yaw0 = yaw(sim)
    assert sim.set_velocity(0.0, 0.0, 0.8, MOVE_CONTINUOUS_DURATION_S) == OK
    run(sim, 2.0)
    turned = math.remainder(yaw(sim) - yaw0, 2 * math.pi)
    assert turned > 1.0  # 0.8 rad/s commanded; the policy tracks ~0.7
    assert not sim.fallen


def test_damp_sinks(sim: SimG1) -> None:
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    run(sim, 3.0)
    assert sim.base_pose().position[2] < 0.3


def test_zero_torque_drops(sim: SimG1) -> None:
    assert sim.set_fsm_id(FsmId.ZERO_TORQUE) == OK
    run(sim, 2.0)
    assert sim.base_pose().position[2] < 0.3
    assert sim.fallen


def test_damp_then_stand_up_before_it_lies_recovers_and_can_walk(sim: SimG1) -> None:
    """Caught while still on its feet (a lying robot gets up only through 702: test_getup.py)."""
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    run(sim, 0.3)
    assert sim.set_fsm_id(FsmId.STAND_UP) == OK
    run(sim, 4.0)
    assert sim.base_pose().position[2] > 0.7
    assert sim.standing_balanced
    assert not sim.fallen
    assert sim.get_fsm_mode() == (OK, FsmMode.STATIC)
    assert sim.set_fsm_id(FsmId.START) == OK


def test_arm_sdk_takes_the_shoulder_and_gives_it_back(sim: SimG1) -> None:
    motor = JOINT_INDEX["right_shoulder_pitch_joint"]
    target = ARM_SDK_HOME.copy()
    target[R_SHOULDER_PITCH] = -1.2  # arm forward and up
    for i in range(50):  # weight 0 -> 1 over 1 s at 50 Hz
        send_arm_sdk(sim, target, (i + 1) / 50)
        run(sim, 0.02)
    run(sim, 0.5)
    assert abs(sim.lowstate().q[motor] - (-1.2)) < 0.15
    for i in range(50):  # and back to 0
        send_arm_sdk(sim, target, 1.0 - (i + 1) / 50)
        run(sim, 0.02)
    run(sim, 1.0)
    assert sim.arm_sdk_weight == 0.0
    assert abs(sim.lowstate().q[motor] - ARM_SDK_HOME[R_SHOULDER_PITCH]) < 0.3  # the policy's pose again
    assert not sim.fallen


def test_lowcmd_moves_joints_after_release(sim: SimG1) -> None:
    assert sim.release_mode() == OK
    assert sim.set_fsm_id(FsmId.DAMP) == ERR_SERVER_API_NOT_IMPL
    elbow = JOINT_INDEX["left_elbow_joint"]
    q = np.zeros(NUM_JOINTS)
    kp = np.zeros(NUM_JOINTS)
    kd = np.zeros(NUM_JOINTS)
    q[elbow], kp[elbow], kd[elbow] = 1.5, 40.0, 1.0
    enabled = np.zeros(NUM_JOINTS, dtype=bool)
    enabled[elbow] = True
    zeros = np.zeros(NUM_JOINTS)
    for _ in range(50):
        sim.apply_lowcmd(q, zeros, zeros, kp, kd, enabled)
        run(sim, 0.02)
    assert abs(sim.lowstate().q[elbow] - 1.5) < 0.15
    assert sim.counters["lowcmd_frames"] == 50
