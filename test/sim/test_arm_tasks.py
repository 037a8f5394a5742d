"""The rest of the G1's high-level surface in the sim: SetArmTask (wave, shake hand), the arm action
service, HighStand/LowStand, with task_id/task_time in rt/sportmodestate.

Driven by this project's LocoClient (the node's adapter) and the SDK's own G1ArmActionClient against the
bridge in a subprocess; judged from what the robot shows: its joints (rt/lowstate), its
rt/sportmodestate and its status.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import numpy as np
import pytest
from unitree_sdk2py.core.channel import ChannelSubscriber
from unitree_sdk2py.g1.arm.g1_arm_action_client import G1ArmActionClient

from g1_mode_manager.core.port import RobotError
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.idl import LowState_, SportModeState_
from g1_mode_manager.protocol.motors import JOINT_INDEX
from g1_mode_manager.sdk.loco_client import LocoClient
from support.sim_bridge import SimStatus, shared_sim_status, sim_bridge_factory  # noqa: F401  (fixture)

pytestmark = pytest.mark.sim

R_ELBOW = JOINT_INDEX["right_elbow_joint"]
R_SHOULDER_PITCH = JOINT_INDEX["right_shoulder_pitch_joint"]
R_SHOULDER_ROLL = JOINT_INDEX["right_shoulder_roll_joint"]


@dataclass
class Clients:
    loco: LocoClient
    arm: G1ArmActionClient
    sport: ChannelSubscriber
    low: ChannelSubscriber
    status: SimStatus

    def q(self) -> np.ndarray:
        self.low.Read(0.05)  # drop a kept older frame
        msg = self.low.Read(2.0)
        assert msg is not None, "no rt/lowstate"
        return np.array([m.q for m in msg.motor_state[:29]])

    def task(self) -> tuple[int, float]:
        msg = self.sport.Read(1.0)
        assert msg is not None, "no rt/sportmodestate"
        return int(msg.task_id), float(msg.task_time)


@functools.cache
def _clients() -> Clients:
    """Kept for the whole session (see support/sim_bridge.py: pitfall)."""
    loco = LocoClient(timeout_s=2.0)
    arm = G1ArmActionClient()
    arm.Init()
    arm.SetTimeout(2.0)
    sport = ChannelSubscriber(topics.SPORTMODESTATE, SportModeState_)
    sport.Init()
    low = ChannelSubscriber(topics.LOWSTATE, LowState_)
    low.Init()
    return Clients(loco, arm, sport, low, shared_sim_status())


def _until(status: SimStatus, predicate, sim_s: float, what: str) -> None:
    """Wait up to ``sim_s`` of sim time (a busy machine slows the sim, not the robot's behaviour)."""
    start = status.get()["sim_time"]
    deadline = time.monotonic() + 60.0
    while not predicate():
        now = status.get()["sim_time"]
        assert now - start < sim_s and time.monotonic() < deadline, \
            f"not within {sim_s} s of sim time: {what}; robot: {status.get()['base']['position']}"
        time.sleep(0.05)


def test_arm_tasks_actions_and_stand_heights(sdk_channels: int, sim_bridge_factory) -> None:  # noqa: F811
    sim_bridge_factory(speed=2.0)
    c = _clients()
    c.status.wait_ready()
    c.loco.wait_ready(10.0)
    assert c.task() == (0, 0.0)

    # WaveHand: the right arm goes up sideways and the forearm waves; the robot reports task 0 with its time.
    q0 = c.q()
    c.loco.wave_hand()
    _until(c.status, lambda: c.task()[1] > 0.0, 2.0, "rt/sportmodestate shows the wave")
    assert c.task()[0] == api.ARM_TASK_WAVE
    elbows, rolls = [], []
    while c.task()[1] > 0.0:  # the wave plays ~6.6 s of sim time
        q = c.q()
        elbows.append(q[R_ELBOW])
        rolls.append(q[R_SHOULDER_ROLL])
    assert min(rolls) < q0[R_SHOULDER_ROLL] - 0.8, "the arm was not raised"
    assert max(elbows) - min(elbows) > 0.35, "the forearm did not wave"
    assert abs(c.q()[R_SHOULDER_ROLL] - q0[R_SHOULDER_ROLL]) < 0.15, "the arm did not come back"

    # Each group from a fresh stand (the sim's reset): chains of motions can tip the sim's lock stand over.
    c.status.reset()
    q0 = c.q()
    # ShakeHand stage 0 holds the hand out (task 2, held); stage 1 withdraws it (task 3), then done.
    c.loco.shake_hand(0)
    _until(c.status, lambda: c.q()[R_SHOULDER_PITCH] < q0[R_SHOULDER_PITCH] - 0.6, 5.0, "hand held out")
    assert c.task()[0] == api.ARM_TASK_SHAKE_HAND_OUT
    c.loco.shake_hand(1)
    _until(c.status, lambda: c.task()[0] == api.ARM_TASK_SHAKE_HAND_BACK, 2.0, "withdraw reported")
    _until(c.status, lambda: c.task() == (0, 0.0), 5.0, "shake hand ended")
    assert abs(c.q()[R_SHOULDER_PITCH] - q0[R_SHOULDER_PITCH]) < 0.15

    c.status.reset()
    q0 = c.q()
    # The arm service (the SDK's own client): its action list, an action, release arm, an unknown id.
    code, actions = c.arm.GetActionList()
    assert code == 0 and {a["id"] for a in actions} >= {26, api.ARM_ACTION_RELEASE}, actions
    assert c.arm.ExecuteAction(26) == 0
    _until(c.status, lambda: c.task()[0] == 26 and c.q()[R_SHOULDER_ROLL] < q0[R_SHOULDER_ROLL] - 0.5, 5.0, "high wave")
    assert c.arm.ExecuteAction(api.ARM_ACTION_RELEASE) == 0
    _until(c.status, lambda: c.task() == (0, 0.0), 5.0, "release arm ended the action")
    assert c.arm.ExecuteAction(5) == api.ERR_SERVER_API_PARAMETER

    c.status.reset()
    # LowStand / HighStand as the SDK sends them (0 / 0xFFFFFFFF): the pelvis sinks to ~0.60 m, rises again.
    c.loco.low_stand()
    _until(c.status, lambda: c.status.get()["base"]["position"][2] < 0.65, 5.0, "low stand")
    c.loco.high_stand()
    _until(c.status, lambda: c.status.get()["base"]["position"][2] > 0.74, 5.0, "high stand")

    # Only while standing still: walking refuses (7301) and nothing plays.
    c.loco.start()
    with pytest.raises(RobotError) as refused:
        c.loco.wave_hand()
    assert refused.value.code == api.ERR_REFUSED_IN_STATE
    assert c.task() == (0, 0.0) and c.status.get()["firmware"].get("falls", 0) == 0
