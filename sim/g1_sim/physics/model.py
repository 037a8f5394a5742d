"""The G1 MuJoCo model, built once with MjSpec from the Menagerie scene: a robot that takes torques."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Final

import mujoco
import numpy as np

from g1_mode_manager.protocol import motors
from g1_mode_manager.protocol.motors import EFFORT_LIMIT_NM, JOINT_NAMES, NUM_JOINTS
from g1_sim.assets import assets_dir, scene_xml
from g1_sim.physics.compiled_cache import compiled_model

TIMESTEP_S: Final = 0.002
#: The locomotion policy's default pose (motor order), rad: legs slightly bent, arms a little out.
_LEG = (-0.312, 0.0, 0.0, 0.669, -0.363, 0.0)
DEFAULT_POSE: Final = np.array(
    (*_LEG, *_LEG, 0.0, 0.0, 0.0, 0.2, 0.2, 0.0, 0.6, 0.0, 0.0, 0.0, 0.2, -0.2, 0.0, 0.6, 0.0, 0.0, 0.0)
)
EFFORT_LIMIT: Final = np.array(EFFORT_LIMIT_NM)
STAND_KEY: Final = "stand"
PELVIS_BODY: Final = "pelvis"
PELVIS_GYRO: Final = "imu-pelvis-angular-velocity"
PELVIS_ACCEL: Final = "imu-pelvis-linear-acceleration"
#: The torso IMU (rt/secondary_imu): Menagerie's model has its site and sensors on torso_link.
TORSO_IMU_SITE: Final = "imu_in_torso"
TORSO_GYRO: Final = "imu-torso-angular-velocity"
TORSO_ACCEL: Final = "imu-torso-linear-acceleration"
#: Joint i (motor order) is qpos[QPOS0 + i] and qvel[QVEL0 + i] (after the pelvis free joint): asserted at build.
QPOS0: Final = 7
QVEL0: Final = 6


@dataclass(frozen=True)
class G1Model:
    """A compiled model plus the addresses the controllers and the firmware read every step."""

    model: mujoco.MjModel
    pelvis_body: int
    gyro_adr: int
    accel_adr: int
    torso_imu_site: int
    torso_gyro_adr: int
    torso_accel_adr: int
    stand_key: int
    stand_poses: StandPoses

    def reset(self, data: mujoco.MjData) -> None:
        """Put the robot in the standing keyframe (policy default pose, feet on the floor)."""
        mujoco.mj_resetDataKeyframe(self.model, data, self.stand_key)
        mujoco.mj_forward(self.model, data)


def _to_torque_motors(spec: mujoco.MjSpec) -> None:
    """Menagerie's actuators are position servos; the real G1 takes torque (plus its own PD from LowCmd)."""
    names = tuple(a.name for a in spec.actuators)
    if names != JOINT_NAMES:
        raise ValueError(f"actuator order of the model differs from the G1 motor order: {names}")
    for act, limit in zip(spec.actuators, EFFORT_LIMIT_NM, strict=True):
        if act.target != act.name:
            raise ValueError(f"actuator {act.name} drives {act.target}, not its namesake joint")
        act.set_to_motor()
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = [-limit, limit]
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-limit, limit]


def standing_qpos(model: mujoco.MjModel, pose: np.ndarray = DEFAULT_POSE) -> np.ndarray:
    """``pose`` with the pelvis upright, lowered until the lowest collision geom touches the floor."""
    data = mujoco.MjData(model)
    qpos = model.qpos0.copy()
    qpos[0:3] = (0.0, 0.0, 1.0)
    qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    qpos[7 : 7 + NUM_JOINTS] = pose
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    robot_geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] != 0 and model.geom_contype[g]]
    lowest = min(data.geom_xpos[g][2] - _geom_half_height(model, data, g) for g in robot_geoms)
    qpos[2] = 1.0 - lowest + 0.002
    return qpos


def _geom_half_height(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> float:
    """Vertical half-extent of a sphere/box/capsule collision geom in its current orientation."""
    size = model.geom_size[g]
    rot = data.geom_xmat[g].reshape(3, 3)
    kind = model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return float(size[0])
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return float(np.abs(rot[2, :]) @ size)
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return float(size[0] + abs(rot[2, 2]) * size[1])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return float(abs(rot[2, 2]) * size[1] + np.hypot(rot[2, 0], rot[2, 1]) * size[0])
    return float(model.geom_rbound[g])


def _compile(root: Path) -> mujoco.MjModel:
    spec = mujoco.MjSpec.from_file(str(scene_xml(root)))
    spec.option.timestep = TIMESTEP_S
    _to_torque_motors(spec)
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, 640)
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, 480)
    return spec.compile()


def build_model(root: str | Path | None = None) -> G1Model:
    """Compile the scene once: torque motors with G1 effort limits, dt 2 ms, keyframe ``stand``."""
    folder = assets_dir(root)
    model = compiled_model(folder, (Path(__file__), Path(motors.__file__)), lambda: _compile(folder))

    for i, name in enumerate(JOINT_NAMES):
        jnt = model.joint(name)
        if jnt.qposadr[0] != QPOS0 + i or jnt.dofadr[0] != QVEL0 + i:
            raise ValueError(f"joint {name} is not at motor index {i} in qpos/qvel")

    stand = standing_qpos(model)
    key = model.key(STAND_KEY).id
    model.key_qpos[key] = stand
    model.key_qvel[key] = 0.0
    model.key_ctrl[key] = 0.0
    return G1Model(
        model=model,
        pelvis_body=model.body(PELVIS_BODY).id,
        gyro_adr=int(model.sensor(PELVIS_GYRO).adr[0]),
        accel_adr=int(model.sensor(PELVIS_ACCEL).adr[0]),
        torso_imu_site=model.site(TORSO_IMU_SITE).id,
        torso_gyro_adr=int(model.sensor(TORSO_GYRO).adr[0]),
        torso_accel_adr=int(model.sensor(TORSO_ACCEL).adr[0]),
        stand_key=key,
        stand_poses=StandPoses(model),
    )


#: Leg pitch joints (hip, knee, ankle) of both legs, motor order.
_PITCH_CHAINS: Final = ((0, 3, 4), (6, 9, 10))
#: Pelvis heights lock stand can reach by bending the knees, m (straight legs ~0.79, deep squat below 0.6).
STAND_HEIGHT_RANGE_M: Final = (0.60, 0.78)


def knee_bent_pose(knee: float, hip_share: float, base: np.ndarray = DEFAULT_POSE) -> np.ndarray:
    """``base`` with both knees at ``knee``; the hips take ``hip_share`` of the bend and the ankles the rest,
    so hip + knee + ankle pitch keep their sum (feet stay parallel to the pelvis)."""
    pose = base.copy()
    for hip, kn, ankle in _PITCH_CHAINS:
        total = base[hip] + base[kn] + base[ankle]
        pose[kn] = knee
        pose[hip] = -hip_share * knee
        pose[ankle] = total - pose[hip] - knee
    return pose


class StandPoses:
    """Standing poses by pelvis height: knees bent further for lower, the hip/ankle split chosen so the
    centre of mass keeps its place over the feet (as in the default pose). Tabulated once per model."""

    def __init__(self, model: mujoco.MjModel, knees: np.ndarray | None = None) -> None:
        data = mujoco.MjData(model)
        feet = [model.body(f"{side}_ankle_roll_link").id for side in ("left", "right")]
        pelvis = model.body(PELVIS_BODY).id

        soles = [g for g in range(model.ngeom) if model.geom_bodyid[g] in feet and model.geom_contype[g]]

        def com_ahead(pose: np.ndarray) -> tuple[float, float]:
            """(centre of mass ahead of the ankles, pelvis height over the soles) of ``pose``, m."""
            data.qpos[:] = model.qpos0
            data.qpos[0:3] = (0.0, 0.0, 1.0)
            data.qpos[QPOS0 : QPOS0 + NUM_JOINTS] = pose
            mujoco.mj_forward(model, data)
            mid = 0.5 * (data.xpos[feet[0]] + data.xpos[feet[1]])
            sole = min(data.geom_xpos[g][2] - _geom_half_height(model, data, g) for g in soles)
            return float(data.subtree_com[pelvis][0] - mid[0]), 1.0 - sole

        default_share = -DEFAULT_POSE[0] / DEFAULT_POSE[3]
        target, self.default_height = com_ahead(DEFAULT_POSE)
        #: How far the centre of mass stands ahead of the mid-point of the ankles, m.
        self.com_ahead = target
        knees = np.linspace(0.1, 2.1, 21) if knees is None else knees
        shares, heights = [], []
        for k in knees:
            lo, hi = 0.2, 0.8  # com_ahead falls as the hip share grows: bisect for the default's offset
            for _ in range(20):
                mid_share = 0.5 * (lo + hi)
                lo, hi = (mid_share, hi) if com_ahead(knee_bent_pose(k, mid_share))[0] > target else (lo, mid_share)
            shares.append(0.5 * (lo + hi))
            heights.append(com_ahead(knee_bent_pose(k, shares[-1]))[1])
        order = np.argsort(heights)
        self._heights = np.asarray(heights)[order]
        self._knees = np.asarray(knees)[order]
        self._shares = np.asarray(shares)[order]
        self.default_share = float(default_share)

    def pose(self, height: float) -> np.ndarray:
        """The standing pose whose pelvis stands at ``height`` m (clamped to :data:`STAND_HEIGHT_RANGE_M`)."""
        h = float(np.clip(height, *STAND_HEIGHT_RANGE_M))
        knee = float(np.interp(h, self._heights, self._knees))
        return knee_bent_pose(knee, float(np.interp(h, self._heights, self._shares)))
