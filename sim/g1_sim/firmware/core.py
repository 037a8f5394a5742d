"""The simulated G1's firmware state: the model, its built-in controllers and the fields every part reads.

One lock guards everything: RPC handlers call in from other threads while a loop thread calls ``step``. The
parts of the firmware (robot.py lists them) are classes over this one state; here is what they all use: which
controller holds the joints and whether it balances, the robot's posture, and the log line of every call.

Boot: by default the robot starts *standing* in lock-stand (fsm 4) with the "ai" service selected,
because that is what a user of the sim wants first. ``start_fsm=0``/``1`` boots limp or damping,
``start_service=""`` boots straight into debug mode (as some robots do). ``start_posture`` "squat" or "lying"
starts the robot folded in a squat or lying on its back (physics/boot_posture.py), damping unless ``start_fsm``
says zero torque: the vendor's power-on flows start there.
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path
from typing import Final

import mujoco
import numpy as np

from g1_mode_manager.protocol.api_ids import ERR_INVALID_FSM_ID, OK
from g1_mode_manager.protocol.fsm import BalanceMode, FsmId, FsmMode
from g1_mode_manager.protocol.motors import NUM_JOINTS
from g1_sim.assets import assets_dir, policy_onnx
from g1_sim.firmware.arm_tasks import ArmTaskPlayer
from g1_sim.firmware.body import Body
from g1_sim.firmware.odometry import Odometer
from g1_sim.firmware.posture import Posture, posture_of
from g1_sim.firmware.state import BasePose
from g1_sim.firmware.user_ctrl import DEFAULT_DELAY_S, DEFAULT_OPTION, UserCtrl, check_delay, parse_option
from g1_sim.physics.battery import START_SOC
from g1_sim.physics.boot_posture import BootPosture, start_in
from g1_sim.physics.controllers import (
    ArmSdkBlend,
    Controller,
    DampController,
    LocomotionController,
    LowLevelController,
    PostureHarness,
    Sensed,
    StanceController,
    StandUpSequence,
    ZeroTorqueController,
)
from g1_sim.physics.fold import FOLDED_PITCH_RAD, FOLDED_POSE
from g1_sim.physics.model import DEFAULT_POSE, G1Model, build_model, standing_qpos
from g1_sim.physics.pelvis_forces import PelvisForces
from g1_sim.physics.placement import place
from g1_sim.physics.policy import RATE_HZ, LocomotionPolicy

log = logging.getLogger("g1_sim.firmware")

#: Names SelectMode accepts (and a boot may start with); CheckMode answers one.
SERVICE_NAMES: Final = frozenset({"ai", "normal", "advanced"})
#: Stand and swing heights reported before any Set*Height, m.
DEFAULT_STAND_HEIGHT_M: Final = 0.75
DEFAULT_SWING_HEIGHT_M: Final = 0.08
#: The lie-to-stand (702) motion's ramp, s: with its hold and hand-over about 5.6 s from the floor to a
#: balanced stand. No vendor source gives the robot's time; a few seconds, slower than the 4 stand-up.
GET_UP_RAMP_S: Final = 4.5


def _pose(hip: float, knee: float, ankle: float) -> np.ndarray:
    pose = DEFAULT_POSE.copy()
    pose[[0, 6]] = hip
    pose[[3, 9]] = knee
    pose[[4, 10]] = ankle
    return pose


SQUAT_POSE: Final = _pose(-1.0, 1.87, -0.87)
SIT_POSE: Final = _pose(-1.6, 2.4, -0.8)

_models: dict[Path, G1Model] = {}
_models_lock = threading.Lock()


def shared_model(root: Path) -> G1Model:
    """Compile once per process (meshes take ~2 s); every SimG1 then gets its own MjData."""
    with _models_lock:
        if root not in _models:
            _models[root] = build_model(root)
        return _models[root]


class FirmwareCore:
    """The robot's state, its controllers and the primitives every part of the firmware uses."""

    def __init__(self, assets: str | Path | None = None, *, start_fsm: int | None = None,
                 start_service: str = "ai", seed: int = 0, start_soc: float = START_SOC,
                 gantry: bool = False, user_ctrl: str = DEFAULT_OPTION,
                 user_ctrl_delay_s: float = DEFAULT_DELAY_S,
                 start_posture: BootPosture | str = BootPosture.STANDING) -> None:
        root = assets_dir(assets).resolve()
        posture = BootPosture(start_posture)
        if start_fsm is None:
            start_fsm = FsmId.STAND_UP if posture is BootPosture.STANDING else FsmId.DAMP
        elif start_fsm == FsmId.STAND_UP and posture is not BootPosture.STANDING:
            raise ValueError(f"a robot booted {posture.value} is limp or damped (fsm 0 or 1), not in fsm 4")
        self._g1 = shared_model(root)
        self._data = mujoco.MjData(self._g1.model)
        start_in(self._g1, self._data, posture)
        if seed:  # seed 0 boots exactly in the keyframe; others jitter the joints a little (N(0, 5 mrad))
            self._data.qpos[7 : 7 + NUM_JOINTS] += np.random.default_rng(seed).normal(0.0, 0.005, NUM_JOINTS)
            mujoco.mj_forward(self._g1.model, self._data)
        self._s = Sensed(self._g1, self._data)
        self._lock = threading.RLock()
        self.dt: float = float(self._g1.model.opt.timestep)
        self._decimation = round(1.0 / (RATE_HZ * self.dt))
        self._steps = 0

        policy = LocomotionPolicy(policy_onnx(root))
        self._loco = LocomotionController(policy)
        self._zero = ZeroTorqueController()
        self._damp = DampController()
        self._lowlevel = LowLevelController()
        self._user = LowLevelController()  # rt/user_lowcmd in user control
        self._uc = UserCtrl(parse_option(user_ctrl), check_delay(user_ctrl_delay_s))
        self._arm = ArmSdkBlend()
        self._tasks = ArmTaskPlayer()  # SetArmTask and the arm service's actions
        self._squat = PostureHarness(self._g1, SQUAT_POSE, float(standing_qpos(self._g1.model, SQUAT_POSE)[2]))
        self._sit = PostureHarness(self._g1, SIT_POSE, float(standing_qpos(self._g1.model, SIT_POSE)[2]))
        folded = place(self._g1.model, FOLDED_POSE, FOLDED_PITCH_RAD)
        self._fold = PostureHarness(self._g1, FOLDED_POSE, folded.height, pitch=FOLDED_PITCH_RAD,
                                    ahead=folded.ahead)  # 706's squat
        self._stance = StanceController(self._g1)
        stand_z = float(self._g1.model.key_qpos[self._g1.stand_key][2])
        self._stand_up = StandUpSequence(self._g1, self._stance, stand_z, kp=policy.kp * 2.0, kd=policy.kd * 2.0)
        self._get_up = StandUpSequence(self._g1, self._stance, stand_z, ramp_s=GET_UP_RAMP_S, kp=policy.kp * 2.0,
                                       kd=policy.kd * 2.0)
        self._squatting = False  # squatted down by 706 (StandUp2Squat)
        self._ctrl: Controller = self._zero
        self._body = Body(start_soc)
        self._forces = PelvisForces(self._g1.pelvis_body)
        self._runaway: tuple[int, float, float] | None = None  # a runaway motor: index, direction, until (sim s)
        self._forces.set_gantry(gantry, self._data)
        self._remote: frozenset[str] = frozenset()
        self._remote_damp_held = False
        self._odometer = Odometer()
        self._torso_quat = np.empty(4)  # scratch for torso_imu

        self._service = ""
        self._silent = False
        self._fsm = int(FsmId.ZERO_TORQUE)
        self._fsm_mode = int(FsmMode.STATIC)
        self._balance_mode = int(BalanceMode.BALANCE_STAND)
        self._speed_mode = 0
        self._stand_height = DEFAULT_STAND_HEIGHT_M
        self._swing_height = DEFAULT_SWING_HEIGHT_M
        self._velocity = np.zeros(3)
        self._velocity_until = 0.0
        self.counters: dict[str, int] = dict.fromkeys(
            ("set_fsm_requests", "damp_requests", "refused", "invalid_fsm", "velocity_requests",
             "arm_sdk_frames", "arm_sdk_ignored", "lowcmd_frames", "lowcmd_ignored", "falls", "remote_damps",
             "pushes", "runaways", "user_ctrl_switches", "user_ctrl_refused", "internal_ctrl_switches", "user_ctrl_ignored_calls",
             "user_lowcmd_frames", "user_lowcmd_ignored", "posture_ignored"), 0)
        self._fallen = posture is BootPosture.LYING  # booted on the floor: not a fall

        if start_service:
            if start_service not in SERVICE_NAMES:
                raise ValueError(f"unknown service {start_service!r}; one of {sorted(SERVICE_NAMES)} or ''")
            self._service = start_service
            self._boot_fsm(int(start_fsm))
        else:
            self._switch(self._lowlevel)

    def _boot_fsm(self, fsm: int) -> None:
        if fsm in (FsmId.ZERO_TORQUE, FsmId.DAMP):
            self._fsm = fsm
            self._switch(self._zero if fsm == FsmId.ZERO_TORQUE else self._damp)
        elif fsm == FsmId.STAND_UP:
            self._fsm = fsm
            self._switch(self._stance)  # the keyframe already stands in the default pose
        else:
            raise ValueError(f"boot fsm must be 0, 1 or 4, not {fsm}")

    @property
    def model(self) -> mujoco.MjModel:
        return self._g1.model

    @property
    def data(self) -> mujoco.MjData:
        """Live MjData: read it under :attr:`lock` if the loop runs in another thread."""
        return self._data

    @property
    def lock(self) -> threading.RLock:
        return self._lock

    @property
    def time(self) -> float:
        return float(self._data.time)

    def base_pose(self) -> BasePose:
        with self._lock:
            d = self._data
            rot = d.xmat[self._g1.pelvis_body].reshape(3, 3)
            return BasePose(position=d.qpos[0:3].copy(), quaternion=d.qpos[3:7].copy(),
                            linear_velocity=d.qvel[0:3].copy(), angular_velocity=rot @ d.qvel[3:6])

    def _switch(self, ctrl: Controller) -> None:
        if ctrl is not self._ctrl:
            self._ctrl.release(self._s)
            ctrl.reset(self._s)
            self._ctrl = ctrl

    def _balanced(self) -> bool:
        """The built-in controller stands or walks on its own (lock stand or policy, stand-up finished)."""
        return self._ctrl in (self._loco, self._stance) or (
            self._ctrl in (self._stand_up, self._get_up) and self._ctrl.done)

    def _transition_running(self) -> bool:
        if self._ctrl in (self._stand_up, self._get_up):
            return not self._ctrl.done
        if self._ctrl in (self._squat, self._sit, self._fold):
            return self._ctrl.progress < 1.0
        return False

    def _posture(self) -> Posture:
        return posture_of(float(self._data.qpos[2]), self._data.qpos[3:7])

    def _log(self, call: str, arg: object, code: int) -> int:
        if code != OK:
            self.counters["refused" if code != ERR_INVALID_FSM_ID else "invalid_fsm"] += 1
        log.info("t=%.2f %s(%s) in fsm %d mode %d service %r -> %d", self.time, call, arg, self._fsm,
                 self._fsm_mode, self._service, code)
        return code
