"""A whole-body motion tracking policy (holosoma's WBT kind): a clip baked into the model, played one frame per tick.

The model holds the motion and is indexed by its ``time_step`` input; besides the action it returns the clip's
frame there (``joint_pos``, ``joint_vel``, ``ref_quat_xyzw`` of the reference body). As holosoma's deploy
(policies/wbt.py) does, the observation of a tick carries the frame the previous inference returned
(``motion_command``) and the orientation of that frame's reference body seen from the robot's own
(``motion_ref_ori_b``), both with the heading they had at activation removed, so the dance starts facing wherever
the robot faces. The first frame comes from an inference at time step 0 with a zero observation.

The clip's length is read off the model itself: past its last frame the model clamps ``time_step`` and keeps
returning that frame, so the first time step whose frame equals the one at a far time step is the end
(holosoma's ``ppo_g1_29dof_dancing.onnx``: 6573 steps, 131.46 s at 50 Hz; ``fastsac_g1_29dof_dancing.onnx``:
6773 steps, 135.46 s). From there on the time step stays pinned at the end and the policy keeps balancing on the
final pose, as holosoma's ``motion_end_timestep`` handling does.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections.abc import Callable
from typing import Final

import numpy as np

from g1_mode_manager.core.controller.interface import Command, ControllerError, JointTargets, RobotState
from g1_mode_manager.policy.action_scale import ActionScale
from g1_mode_manager.policy.deploy_config import DeployConfig
from g1_mode_manager.policy.model import PolicyModel
from g1_mode_manager.policy.observation import ObservationBuilder, common_terms
from g1_mode_manager.protocol.motors import JOINT_INDEX, NUM_JOINTS

#: The model's clock input and the outputs a tick uses (holosoma's WBT ONNX export).
TIME_STEP_INPUT: Final = "time_step"
_OUTPUTS: Final = ("actions", "joint_pos", "joint_vel", "ref_quat_xyzw")
_OUTPUT_SIZES: Final = (NUM_JOINTS, NUM_JOINTS, NUM_JOINTS, 4)

#: The body whose orientation the policy tracks: holosoma's g1_29dof ``motion.body_name_ref`` (robot.py).
REFERENCE_BODY: Final = "torso_link"

#: pelvis -> torso_link in the G1 URDF: (joint, parent link, child link, rotation axis).
WAIST_CHAIN: Final = (
    ("waist_yaw_joint", "pelvis", "waist_yaw_link", (0.0, 0.0, 1.0)),
    ("waist_roll_joint", "waist_yaw_link", "waist_roll_link", (1.0, 0.0, 0.0)),
    ("waist_pitch_joint", "waist_roll_link", REFERENCE_BODY, (0.0, 1.0, 0.0)),
)
_WAIST: Final = [JOINT_INDEX[joint] for joint, *_ in WAIST_CHAIN]

#: float32 (the type of ``time_step``) holds every integer up to 2**24: the farthest time step asked for.
_FAR_STEP: Final = 1 << 24


def _rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def quat_wxyz_to_matrix(quat_wxyz: np.ndarray) -> np.ndarray:
    """The rotation of a quaternion (w, x, y, z), normalised first: the IMU's and the clip's may drift off 1."""
    w, x, y, z = np.asarray(quat_wxyz, dtype=float) / np.linalg.norm(quat_wxyz)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def torso_orientation(pelvis_wxyz: np.ndarray, waist_yaw: float, waist_roll: float, waist_pitch: float) -> np.ndarray:
    """World-from-``torso_link`` rotation (3x3): the pelvis IMU's orientation carried through the waist.

    holosoma runs pinocchio's forward kinematics on the whole URDF for this one rotation; only the waist lies
    between the pelvis and the torso, so three rotations do. In the G1 29-dof URDF the model carries
    (``robot_urdf`` metadata): ``waist_yaw_joint`` pelvis -> waist_yaw_link about z, ``waist_roll_joint``
    -> waist_roll_link about x, ``waist_pitch_joint`` -> torso_link about y, every origin without rotation
    (rpy 0; checked at load by :func:`check_waist_chain`); ``imu_in_pelvis_joint`` has none either, so the IMU's
    orientation is the pelvis's.
    """
    return quat_wxyz_to_matrix(pelvis_wxyz) @ _rot_z(waist_yaw) @ _rot_x(waist_roll) @ _rot_y(waist_pitch)


def yaw_of(rotation: np.ndarray) -> float:
    """The heading of a rotation (the z of a ZYX roll-pitch-yaw)."""
    return float(np.arctan2(rotation[1, 0], rotation[0, 0]))


def without_yaw(rotation: np.ndarray, yaw: float) -> np.ndarray:
    """``rotation`` turned back by ``yaw`` about the world's vertical."""
    return _rot_z(-yaw) @ rotation


def turning_rates(before: np.ndarray, after: np.ndarray, dt_s: float) -> np.ndarray:
    """How fast a body turned from rotation ``before`` to ``after`` in ``dt_s``, about each axis of its own frame
    (as a gyro reads it): |angular velocity| x, y, z, rad/s."""
    delta = before.T @ after
    angle = float(np.arccos(np.clip((np.trace(delta) - 1.0) / 2.0, -1.0, 1.0)))
    axis = np.array([delta[2, 1] - delta[1, 2], delta[0, 2] - delta[2, 0], delta[1, 0] - delta[0, 1]])
    norm = float(np.linalg.norm(axis))
    if angle < 1e-9:
        return np.zeros(3)
    if norm < 1e-12:  # a half turn in one tick: the axis is not in the antisymmetric part; bound every axis by it
        return np.full(3, angle / dt_s)
    return np.abs(axis / norm) * angle / dt_s


def ref_ori_b(robot: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """The clip's reference body orientation in the robot's (robot^-1 * motion), as its rotation's first two
    columns read row by row: holosoma's ``matrix_from_quat(...)[..., :2].reshape(1, -1)`` layout."""
    return (robot.T @ motion)[:, :2].reshape(6)


def check_waist_chain(urdf_text: str, policy: str) -> ET.Element:
    """The model's URDF, parsed, after checking that its waist is what :func:`torso_orientation` assumes."""
    try:
        root = ET.fromstring(urdf_text)
    except ET.ParseError as exc:
        raise ControllerError(f"policy {policy}: the model's robot_urdf is not valid XML: {exc}") from exc
    joints = {j.get("name"): j for j in root.iter("joint")}
    for name, parent, child, axis in WAIST_CHAIN:
        joint = joints.get(name)
        if joint is None:
            raise ControllerError(f"policy {policy}: the model's URDF has no {name}")
        origin, found_axis = joint.find("origin"), joint.find("axis")
        rpy = _floats(origin.get("rpy", "0 0 0") if origin is not None else "0 0 0", name)
        xyz = _floats(found_axis.get("xyz", "1 0 0") if found_axis is not None else "1 0 0", name)
        links = (_attr(joint, "parent"), _attr(joint, "child"))
        if (joint.get("type") != "revolute" or links != (parent, child) or np.any(np.abs(rpy) > 1e-9)
                or not np.allclose(xyz / np.linalg.norm(xyz), axis)):
            raise ControllerError(f"policy {policy}: the model's URDF has {name} as {joint.get('type')} "
                                  f"{links[0]} -> {links[1]}, axis {xyz.tolist()}, rpy {rpy.tolist()}; expected "
                                  f"revolute {parent} -> {child}, axis {list(axis)}, rpy 0")
    return root


def _attr(joint: ET.Element, tag: str) -> str | None:
    element = joint.find(tag)
    return element.get("link") if element is not None else None


def _floats(text: str, joint: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise ControllerError(f"the model's URDF has a non-numeric vector on {joint}: {text!r}") from None
    if values.shape != (3,):
        raise ControllerError(f"the model's URDF has a vector of {values.size} values on {joint}: {text!r}")
    return values


def _metadata_json(metadata: dict[str, str], key: str, policy: str) -> object:
    try:
        return json.loads(metadata[key])
    except ValueError:
        raise ControllerError(f"policy {policy}: the model's {key} metadata is not JSON") from None


def clip_end(frame_at: Callable[[int], tuple[np.ndarray, ...]], policy: str) -> int:
    """The time step of the clip's last frame: the first from which the model returns the frame it returns at
    the farthest time step (it clamps there); found by doubling then bisection, about 30 inferences."""
    final = frame_at(_FAR_STEP)

    def at_end(step: int) -> bool:
        return all(np.array_equal(a, b) for a, b in zip(frame_at(step), final, strict=True))

    if at_end(0):
        raise ControllerError(f"policy {policy}: its motion does not move (time step 0 already gives its last frame)")
    before, end = 0, 1
    while not at_end(end):
        before, end = end, end * 2
        if end >= _FAR_STEP:
            raise ControllerError(f"policy {policy}: its motion has no last frame below time step {_FAR_STEP}")
    while end - before > 1:
        mid = (before + end) // 2
        before, end = (before, mid) if at_end(mid) else (mid, end)
    if not (at_end(end + 1) and at_end(2 * end)):
        raise ControllerError(f"policy {policy}: its motion does not stay on its last frame past time step {end}")
    return end


class MotionTrackingController:
    def __init__(self, config: DeployConfig, model: PolicyModel, scale: ActionScale) -> None:
        self.name = config.name
        self.rate_hz = config.rate_hz
        self._config = config
        self._model = model
        if np.shape(config.default_pose) != (NUM_JOINTS,):
            raise ControllerError(f"policy {config.name}: default_pose must have {NUM_JOINTS} values, got "
                                  f"{np.size(config.default_pose)}")
        inputs, obs_input = model.inputs, config.observation.input
        if set(inputs) != {obs_input, TIME_STEP_INPUT}:
            raise ControllerError(f"policy {config.name}: the model takes {list(inputs)}, a tracking policy takes "
                                  f"{obs_input!r} (its config's observation) and {TIME_STEP_INPUT!r}")
        for output, size in zip(_OUTPUTS, _OUTPUT_SIZES, strict=True):
            if model.outputs.get(output) != size:
                raise ControllerError(f"policy {config.name}: the model needs an output {output!r} of {size} values, "
                                      f"its outputs are {model.outputs}")
        self._obs = ObservationBuilder(config.observation, inputs[obs_input], config.name)
        if "robot_urdf" not in model.metadata:
            raise ControllerError(f"policy {config.name}: the model carries no robot_urdf metadata (its waist "
                                  "kinematics and effort limits)")
        check_waist_chain(str(_metadata_json(model.metadata, "robot_urdf", config.name)), config.name)
        self.action_scale = scale.values
        self.action_scale_rule = scale.rule
        self._zero_obs = np.zeros((1, inputs[obs_input]), dtype=np.float32)
        self._time = np.zeros((1, 1), dtype=np.float32)
        #: The time step of the clip's last frame: its length in ticks.
        self.motion_steps = clip_end(lambda t: tuple(self._run(self._zero_obs, t)[1:]), config.name)
        self._zeros = np.zeros(NUM_JOINTS)
        self._active = False
        self.reference_q = np.zeros(NUM_JOINTS)  # the clip's latest joint positions (motor order, rad)
        self.reference_dq = np.zeros(NUM_JOINTS)  # and speeds (rad/s)
        self.reference_rates = np.zeros(3)  # how fast its reference body turned into the latest frame (rad/s, x y z)
        self._motion_ref: np.ndarray | None = None
        self.last_action = np.zeros(NUM_JOINTS)
        self._step = 0
        self.start_hold_s = config.start_hold_s
        self.model_path = config.model
        self.policy_kp = config.kp  # the gains of its own frames (the engage's blend uses the ready ones)
        self._hold_ticks = round(config.start_hold_s * config.rate_hz)
        self._held = 0  # ticks run at the first time step since activation

    def _run(self, obs: np.ndarray, step: int) -> list[np.ndarray]:
        self._time[0, 0] = step
        outputs = self._model.run(list(_OUTPUTS), {self._config.observation.input: obs, TIME_STEP_INPUT: self._time})
        values = [np.asarray(o, dtype=float).reshape(-1) for o in outputs]
        if not all(np.all(np.isfinite(v)) for v in values):
            raise ControllerError(f"policy {self.name}: non-finite output from the model at time step {step}")
        return values

    def _take_frame(self, joint_pos: np.ndarray, joint_vel: np.ndarray, ref_quat_xyzw: np.ndarray) -> None:
        self.reference_q, self.reference_dq = joint_pos, joint_vel
        self._motion_command = np.concatenate([joint_pos, joint_vel])
        x, y, z, w = ref_quat_xyzw
        after = quat_wxyz_to_matrix(np.array([w, x, y, z]))
        before, self._motion_ref = self._motion_ref, after
        self.reference_rates = np.zeros(3) if before is None else turning_rates(before, after, 1.0 / self.rate_hz)

    def _robot_ref(self, state: RobotState) -> np.ndarray:
        return torso_orientation(state.quaternion_wxyz, *state.q[_WAIST])

    def activate(self, state: RobotState) -> None:
        """Rewind the clip to its first frame and take both headings (the robot's torso, the clip's first
        frame) as the ones to remove from then on."""
        self.last_action = np.zeros(NUM_JOINTS)
        self._step = 0
        self._held = 0
        self._motion_ref = None
        self._take_frame(*self._run(self._zero_obs, 0)[1:])
        self._motion_yaw = yaw_of(self._motion_ref)
        self._robot_yaw = yaw_of(self._robot_ref(state))
        self._active = True

    def deactivate(self) -> None:
        self._active = False
        self.last_action = np.zeros(NUM_JOINTS)

    def progress(self) -> float:
        return self._step / self.motion_steps

    def reference(self) -> np.ndarray:
        return self.reference_q

    def reference_speeds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.reference_dq, self.reference_rates

    def ready(self) -> JointTargets:
        """The pose the engage blends to before the policy starts, held with the config's ready gains: the default
        pose (holosoma's flow: a stiff hold of the default pose under ``stiff_startup_kp``, then the policy at the
        clip's first time step, then the clip), or the clip's first frame."""
        c = self._config
        first = c.default_pose if c.ready_pose == "default" else self._run(self._zero_obs, 0)[1]
        kp = c.kp if c.ready_kp is None else c.ready_kp
        kd = c.kd if c.ready_kd is None else c.ready_kd
        return JointTargets(q=first, dq=self._zeros, tau=self._zeros, kp=kp, kd=kd)

    def step(self, state: RobotState, command: Command) -> JointTargets:
        """One tick at the clip's current time step, then the clock advances (held at the first time step for the
        config's start hold, and at the last frame)."""
        if not self._active:
            raise ControllerError(f"policy {self.name}: stepped while not active")
        c = self._config
        values = common_terms(state, c.default_pose, self.last_action)
        values.update(motion_command=self._motion_command, motion_ref_ori_b=ref_ori_b(
            without_yaw(self._robot_ref(state), self._robot_yaw), without_yaw(self._motion_ref, self._motion_yaw)))
        action, *frame = self._run(self._obs.build(values), self._step)
        self._take_frame(*frame)
        if self._held < self._hold_ticks:
            self._held += 1
        else:
            self._step = min(self._step + 1, self.motion_steps)
        self.last_action = np.clip(action, -c.action_clip, c.action_clip)
        return JointTargets(q=c.default_pose + self.action_scale * self.last_action, dq=self._zeros, tau=self._zeros,
                            kp=c.kp, kd=c.kd)
