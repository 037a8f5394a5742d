"""The walking torso stabiliser under rt/arm_sdk (LocomotionController): on only while arm_sdk has weight
on a walking robot, capped, and gone when the weight is; with it the grid's hardest cell holds."""

from __future__ import annotations

import numpy as np
import pytest

from g1_mode_manager.protocol.api_ids import MOVE_CONTINUOUS_DURATION_S, OK
from g1_mode_manager.protocol.fsm import FsmId
from g1_sim.firmware import SimG1
from g1_sim.physics.controllers import ASSIST_LIMIT_NM
from sim.test_stance import ARMS, arm_sdk_program, run

pytestmark = pytest.mark.sim

WAIST_TURNED_ARMS_OUT = {"waist_yaw": 1.5, "left_shoulder_roll": np.pi / 2, "right_shoulder_roll": -np.pi / 2}


def walking(vx: float) -> SimG1:
    sim = SimG1()
    assert sim.set_fsm_id(FsmId.START) == OK
    assert sim.set_velocity(vx, 0.0, 0.0, MOVE_CONTINUOUS_DURATION_S) == OK
    run(sim, 2.0)
    return sim


def pelvis_torque(sim: SimG1) -> np.ndarray:
    return sim._data.xfrc_applied[sim._g1.pelvis_body].copy()


def test_no_torque_while_walking_without_arm_sdk_and_none_left_after_it() -> None:
    sim = walking(0.3)
    seen = []
    for _ in range(100):
        run(sim, 0.01)
        seen.append(np.abs(pelvis_torque(sim)).max())
    assert max(seen) == 0.0 and sim.walk_assist_nm == 0.0
    q = sim.lowstate().q[ARMS].copy()
    zeros, gains = np.zeros(len(ARMS)), np.full(len(ARMS), 60.0)
    peaks = []
    for _ in range(50):  # 1 s of arm_sdk at weight 1 (holding the pose)
        sim.apply_arm_sdk(q, zeros, zeros, gains, np.full(len(ARMS), 1.5), 1.0)
        run(sim, 0.02)
        peaks.append(sim.walk_assist_nm)
        assert np.allclose(pelvis_torque(sim)[:3], 0.0)  # a torque only: never holds the robot up
        assert pelvis_torque(sim)[5] == 0.0  # roll and pitch only: never turns it
    assert 0.0 < max(peaks) <= ASSIST_LIMIT_NM + 1e-9
    sim.apply_arm_sdk(q, zeros, zeros, gains, np.full(len(ARMS), 1.5), 0.0)
    run(sim, 0.1)
    assert sim.walk_assist_nm == 0.0 and np.abs(pelvis_torque(sim)).max() == 0.0


def test_waist_turned_with_arms_out_while_walking_holds() -> None:
    """The grid's hardest cells (they fell without the stabiliser): waist yaw +1.5 rad, arms out, 0.3 m/s."""
    sim = walking(0.3)
    assert arm_sdk_program(sim, WAIST_TURNED_ARMS_OUT, hold_s=1.0) > 0.6
    run(sim, 3.0)
    assert not sim.fallen and sim.base_pose().position[2] > 0.6
