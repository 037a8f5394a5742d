"""The whole-body tracking controller on holosoma's dance models: the torso kinematics, the observation, the clip's
clock and the targets, without ROS (the models come from ``scripts/fetch_assets.py``)."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from g1_mode_manager.core.controller.clamps import TargetClamp
from g1_mode_manager.core.controller.interface import Command, ControllerError, RobotState
from g1_mode_manager.core.controller.targets import frame_of
from g1_mode_manager.policy.action_scale import ActionScale, resolve_action_scale, urdf_effort_limits
from g1_mode_manager.policy.deploy_config import DeployConfig, parse_deploy_config, read_config, resolve_model
from g1_mode_manager.policy.loader import load_policy
from g1_mode_manager.policy.model import PolicyModel
from g1_mode_manager.policy.motion_tracking import (
    MotionTrackingController,
    check_waist_chain,
    quat_wxyz_to_matrix,
    torso_orientation,
)
from g1_mode_manager.policy.observation import TERM_SIZES
from g1_mode_manager.protocol.motors import NUM_JOINTS

POLICY_DIR = Path(sys.prefix) / "share/g1_mode_manager/sim_assets/policy"
UPRIGHT = np.array([1.0, 0.0, 0.0, 0.0])
#: The clip's length in ppo_g1_29dof_dancing.onnx (the figure its config and module document).
PPO_DANCE_STEPS = 6573


def _config(policy: str) -> tuple[DeployConfig, PolicyModel]:
    name, raw = read_config(policy)
    model = PolicyModel(resolve_model(name, raw, POLICY_DIR))
    return parse_deploy_config(raw, name=name, model=model.path, metadata=model.metadata), model


def _scale(config: DeployConfig, model: PolicyModel) -> ActionScale:
    return resolve_action_scale(config.name, config.kind, config.action_scale, model.metadata, config.kp,
                                urdf_effort_limits(config.name, model.metadata))


def _standing(pose: np.ndarray) -> RobotState:
    return RobotState.of(pose, np.zeros(NUM_JOINTS), UPRIGHT, np.zeros(3), 0.0)


def _rz(a: float) -> np.ndarray:
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


def _ry(a: float) -> np.ndarray:
    return np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])


@pytest.fixture(scope="module")
def ppo() -> MotionTrackingController:
    controller = load_policy("dance_ppo", POLICY_DIR)
    assert isinstance(controller, MotionTrackingController)
    return controller


def test_the_torso_is_the_pelvis_at_zero_waist_angles() -> None:
    quarter_turn_z = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    assert np.allclose(quat_wxyz_to_matrix(quarter_turn_z), [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    rng = np.random.default_rng(3)
    for _ in range(5):
        pelvis = rng.normal(size=4)
        pelvis /= np.linalg.norm(pelvis)
        assert np.allclose(torso_orientation(pelvis, 0.0, 0.0, 0.0), quat_wxyz_to_matrix(pelvis))


def test_a_waist_yaw_turns_the_torso_about_the_pelvis_vertical_before_roll_and_pitch() -> None:
    assert np.allclose(torso_orientation(UPRIGHT, 0.3, 0.0, 0.0), _rz(0.3))
    pelvis_on_its_side = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])  # 90 deg about x
    on_side = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    assert np.allclose(torso_orientation(pelvis_on_its_side, 0.3, 0.0, 0.0), on_side @ _rz(0.3))
    # the URDF's chain order: yaw (z) first, then roll, then pitch (y); the other order gives another rotation
    assert np.allclose(torso_orientation(UPRIGHT, 0.3, 0.0, 0.2), _rz(0.3) @ _ry(0.2))
    assert not np.allclose(_rz(0.3) @ _ry(0.2), _ry(0.2) @ _rz(0.3))


def test_the_models_urdf_has_the_waist_the_kinematics_assumes_and_another_is_refused() -> None:
    _, model = _config("dance_ppo")
    urdf = json.loads(model.metadata["robot_urdf"])
    check_waist_chain(urdf, "dance_ppo")
    start = urdf.index('<joint name="waist_roll_joint"')
    tilted = urdf[:start] + urdf[start:].replace('<axis xyz="1 0 0"/>', '<axis xyz="0 1 0"/>', 1)
    assert tilted != urdf
    with pytest.raises(ControllerError, match="waist_roll_joint"):
        check_waist_chain(tilted, "dance_ppo")


class _Recording:
    """The model, with every inference's feeds and outputs kept."""

    def __init__(self, model: PolicyModel) -> None:
        self._model = model
        self.path, self.metadata, self.inputs, self.outputs = model.path, model.metadata, model.inputs, model.outputs
        self.calls: list[tuple[dict[str, np.ndarray], list[np.ndarray]]] = []

    def run(self, outputs: list[str], feeds: dict[str, np.ndarray]) -> list[np.ndarray]:
        result = self._model.run(outputs, feeds)
        self.calls.append(({k: np.array(v) for k, v in feeds.items()}, [np.array(r) for r in result]))
        return result


def test_the_observation_carries_the_previous_inferences_frame_and_targets_scale_the_action() -> None:
    config, model = _config("dance_ppo")
    config = dataclasses.replace(config, start_hold_s=0.0)
    recording = _Recording(model)
    controller = MotionTrackingController(config, recording, _scale(config, model))  # type: ignore[arg-type]
    at = sum(TERM_SIZES[t] for t in config.observation.terms[:config.observation.terms.index("motion_command")])
    controller.activate(_standing(config.default_pose))
    previous = recording.calls[-1]
    assert previous[0]["time_step"][0, 0] == 0.0 and not previous[0]["obs"].any()  # the first frame: zero obs
    for tick in range(4):
        targets = controller.step(_standing(config.default_pose), Command())
        feeds, (action, joint_pos, joint_vel, _) = recording.calls[-1]
        assert feeds["obs"].shape == (1, 154) and feeds["time_step"][0, 0] == tick
        _, (_, previous_pos, previous_vel, _) = previous
        assert np.array_equal(feeds["obs"][0, at:at + 2 * NUM_JOINTS], np.concatenate([previous_pos, previous_vel], 1)[0])
        assert np.allclose(targets.q, config.default_pose + controller.action_scale * action[0])
        assert np.allclose(controller.reference_q, joint_pos[0]) and np.allclose(controller.reference_dq, joint_vel[0])
        previous = recording.calls[-1]
    # holosoma's per-joint scale for these models: 0.25 * effort limit / kp (robot.py G1_29DOF_PER_JOINT_ACTION_SCALE)
    assert np.allclose(controller.action_scale[[0, 1, 4, 20]], [0.547546465219, 0.350661466378, 0.438577313919,
                                                                0.074500870329])


def test_progress_rises_to_one_over_the_clip_after_the_start_hold_and_stays_there(ppo: MotionTrackingController) -> None:
    assert ppo.motion_steps == PPO_DANCE_STEPS  # 131.46 s at 50 Hz
    state = _standing(ppo._config.default_pose)
    ppo.activate(state)
    assert ppo.progress() == 0.0
    hold = round(ppo._config.start_hold_s * ppo.rate_hz)
    assert hold == 100  # the shipped configs' 2 s at the first time step
    first = None
    for _ in range(hold):
        ppo.step(state, Command())
        assert ppo.progress() == 0.0
        first = ppo.reference_q.copy() if first is None else first
        assert np.array_equal(ppo.reference_q, first)  # the clip's first frame, tick after tick
    for tick in range(1, ppo.motion_steps + 1):
        ppo.step(state, Command())
        assert ppo.progress() == pytest.approx(tick / ppo.motion_steps)
    ppo.step(state, Command())  # plays the last frame
    held = ppo.reference_q.copy()
    for _ in range(3):
        ppo.step(state, Command())
        assert ppo.progress() == 1.0
        assert np.array_equal(ppo.reference_q, held)  # the clock stays pinned at the last frame
    ppo.activate(state)
    assert ppo.progress() == 0.0


@pytest.mark.parametrize("policy", ["dance_fastsac", "dance_ppo"])
def test_targets_across_the_clip_on_the_reference_pose_are_finite_and_pass_the_frame_check_clamped(policy: str) -> None:
    """On a robot held exactly at the clip's reference (not a robot's state: a real one lags it, and the policy then
    asks for joints past their stops for longer than on the sim; bench.dance_playback measures that), every target is
    finite and, clamped into range + margin as the loop clamps it, a frame the robot takes."""
    controller = load_policy(policy, POLICY_DIR)
    assert isinstance(controller, MotionTrackingController)
    clamp = TargetClamp(max_held_s=1e9)
    controller.activate(_standing(controller._config.default_pose))
    ticks = round(controller._config.start_hold_s * controller.rate_hz) + controller.motion_steps + 2
    for tick in range(ticks):
        state = RobotState.of(controller.reference_q, controller.reference_dq, UPRIGHT, np.zeros(3), 0.0)
        targets = controller.step(state, Command())
        assert np.all(np.isfinite(targets.q))
        frame_of(clamp.apply(targets, tick / controller.rate_hz))
    assert controller.progress() == 1.0


def test_the_engage_blends_to_the_default_pose_or_the_clips_first_frame_under_the_ready_gains() -> None:
    config, model = _config("dance_ppo")
    assert config.ready_pose == "default"
    controller = MotionTrackingController(config, model, _scale(config, model))
    ready = controller.ready()
    assert np.array_equal(ready.q, config.default_pose) and np.array_equal(ready.kp, config.ready_kp)
    controller = MotionTrackingController(dataclasses.replace(config, ready_pose="first_frame"), model, _scale(config, model))
    controller.activate(_standing(config.default_pose))
    assert np.allclose(controller.ready().q, controller.reference_q)  # activation took the first frame
    assert np.abs(controller.ready().q - config.default_pose).max() > 1.0  # ppo's clip starts mid-dance
    name, raw = read_config("dance_ppo")
    for key, bad in (("ready_pose", "frame_zero"), ("start_hold_s", -1.0), ("start_hold_s", "x")):
        with pytest.raises(ControllerError, match=key):
            parse_deploy_config({**raw, key: bad}, name=name, model=model.path, metadata=model.metadata)


def test_a_default_pose_of_the_wrong_length_is_refused() -> None:
    name, raw = read_config("dance_ppo")
    config, model = _config("dance_ppo")
    with pytest.raises(ControllerError, match="default_pose"):
        parse_deploy_config({**raw, "default_pose": raw["default_pose"][:-1]}, name=name, model=model.path,
                            metadata=model.metadata)
    with pytest.raises(ControllerError, match="default_pose"):
        MotionTrackingController(dataclasses.replace(config, default_pose=config.default_pose[:-1]), model,
                                 _scale(config, model))


def test_the_reference_bodys_turning_rate_is_read_about_each_of_its_axes() -> None:
    from g1_mode_manager.policy.motion_tracking import turning_rates

    assert np.allclose(turning_rates(np.eye(3), _rz(0.1), 0.02), [0.0, 0.0, 5.0])
    tilted = _ry(0.3)  # a yaw of the tilted body is about its own z, as its gyro reads it
    assert np.allclose(turning_rates(tilted, tilted @ _rz(0.1), 0.02), [0.0, 0.0, 5.0])
    assert np.allclose(turning_rates(np.eye(3), np.eye(3), 0.02), 0.0)
