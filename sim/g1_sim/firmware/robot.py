"""SimG1: the simulated robot as the DDS bridge sees it (sport service, motion switcher, streams, state).

One lock guards everything: RPC handlers call in from other threads while a loop thread calls
:meth:`SimG1.step`. Switching rules live in :mod:`g1_sim.firmware.rules`; torques come from the
controllers in :mod:`g1_sim.physics.controllers`; this module wires the two to the physics.

Boot: by default the robot starts *standing* in lock-stand (fsm 4) with the "ai" service selected,
because that is what a user of the sim wants first. ``start_fsm=0``/``1`` boots limp or damping,
``start_service=""`` boots straight into debug mode (as some robots do).

The body around the motors: temperatures and battery (firmware.body), the operator's remote (L2+B damps,
firmware.rules), and forces from outside on the pelvis: the gantry and pushes (physics.pelvis_forces).
The state estimator (rt/odommodestate) is firmware.odometry's: the truth with drift and noise.

User control (7110/7111, rt/user_lowcmd; newer firmware): the rules are firmware.user_ctrl's; here the joints
change hands. In force, a LowLevelController of its own takes the newest user frame received since the switch.
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path
from typing import Final

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from g1_mode_manager.protocol.api_ids import (
    ERR_INVALID_FSM_ID,
    ERR_REFUSED_IN_STATE,
    ERR_SERVER_API_NOT_IMPL,
    ERR_SERVER_API_PARAMETER,
    OK,
)
from g1_mode_manager.protocol.fsm import (
    SPEED_MODE_MAX_SPEED,
    STANDING_FSM_IDS,
    USER_CTRL_FSM_ID,
    WALKING_FSM_IDS,
    BalanceMode,
    FsmId,
    FsmMode,
    InternalCtrl,
)
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS, MODE_MACHINE_G1_29DOF, NUM_JOINTS
from g1_sim.assets import assets_dir, policy_onnx
from g1_sim.firmware import rules
from g1_sim.firmware.arm_tasks import (
    ARM_ACTION_NAMES,
    ARM_ACTIONS,
    RELEASE_ARM,
    RELEASE_MOTION,
    SPORT_TASKS,
    ArmTaskPlayer,
)
from g1_sim.firmware.body import Body
from g1_sim.firmware.odometry import OdomErrors, OdomEstimate, Odometer
from g1_sim.firmware.posture import Posture, posture_of
from g1_sim.firmware.state import BasePose, BodySnapshot, ImuSnapshot, LowStateSnapshot, quat_to_rpy, rpy_of, tilt_rad
from g1_sim.firmware.user_ctrl import (
    DEFAULT_DELAY_S,
    DEFAULT_OPTION,
    UserCtrl,
    UserCtrlOption,
    check_delay,
    internal_target,
    parse_option,
    switch_in_verdict,
)
from g1_sim.physics.battery import START_SOC
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
from g1_sim.physics.model import DEFAULT_POSE, STAND_HEIGHT_RANGE_M, G1Model, build_model, standing_qpos
from g1_sim.physics.pelvis_forces import PelvisForces
from g1_sim.physics.policy import RATE_HZ, LocomotionPolicy

log = logging.getLogger("g1_sim.firmware")

#: Names SelectMode accepts; CheckMode answers (FORM, name).
SERVICE_NAMES: Final = frozenset({"ai", "normal", "advanced"})
FORM: Final = "0"
#: Stand and swing heights reported before any Set*Height, m.
DEFAULT_STAND_HEIGHT_M: Final = 0.75
DEFAULT_SWING_HEIGHT_M: Final = 0.08
#: The policy was trained on commands in [-1, 1] (ONNX metadata), so faster requests are clamped.
POLICY_MAX_COMMAND: Final = 1.0
#: SetStandHeight's HighStand value (LowStand is 0): a uint32 all ones, meaning "the highest".
HIGH_STAND: Final = 0xFFFFFFFF
#: Fall detector: pelvis below this and tilted more than FALL_TILT_RAD.
FALL_HEIGHT_M: Final = 0.4
FALL_TILT_RAD: Final = 0.8
#: The lie-to-stand (702) motion's ramp, s: with its hold and hand-over about 5.6 s from the floor to a
#: balanced stand. No vendor source gives the robot's time; a few seconds, slower than the 4 stand-up.
GET_UP_RAMP_S: Final = 4.5


def _posture(hip: float, knee: float, ankle: float) -> np.ndarray:
    pose = DEFAULT_POSE.copy()
    pose[[0, 6]] = hip
    pose[[3, 9]] = knee
    pose[[4, 10]] = ankle
    return pose


SQUAT_POSE: Final = _posture(-1.0, 1.87, -0.87)
SIT_POSE: Final = _posture(-1.6, 2.4, -0.8)

_ALL_ENABLED: Final = np.ones(NUM_JOINTS, dtype=np.uint8)
_ALL_ENABLED.flags.writeable = False

_models: dict[Path, G1Model] = {}
_models_lock = threading.Lock()


def shared_model(root: Path) -> G1Model:
    """Compile once per process (meshes take ~2 s); every SimG1 then gets its own MjData."""
    with _models_lock:
        if root not in _models:
            _models[root] = build_model(root)
        return _models[root]


class SimG1:
    """The simulated G1 and its firmware rules. Return values are RPC codes of ``protocol.api_ids``."""

    def __init__(self, assets: str | Path | None = None, *, start_fsm: int = FsmId.STAND_UP,
                 start_service: str = "ai", seed: int = 0, start_soc: float = START_SOC,
                 gantry: bool = False, user_ctrl: str = DEFAULT_OPTION,
                 user_ctrl_delay_s: float = DEFAULT_DELAY_S) -> None:
        root = assets_dir(assets).resolve()
        self._g1 = shared_model(root)
        self._data = mujoco.MjData(self._g1.model)
        self._g1.reset(self._data)
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
        self._stance = StanceController(self._g1)
        stand_z = float(self._g1.model.key_qpos[self._g1.stand_key][2])
        self._stand_up = StandUpSequence(self._g1, self._stance, stand_z, kp=policy.kp * 2.0, kd=policy.kd * 2.0)
        self._get_up = StandUpSequence(self._g1, self._stance, stand_z, ramp_s=GET_UP_RAMP_S, kp=policy.kp * 2.0,
                                       kd=policy.kd * 2.0)
        self._squatting = False  # squatted down by 706 (StandUp2Squat)
        self._ctrl: Controller = self._zero
        self._body = Body(start_soc)
        self._forces = PelvisForces(self._g1.pelvis_body)
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
             "pushes", "user_ctrl_switches", "user_ctrl_refused", "internal_ctrl_switches", "user_ctrl_ignored_calls",
             "user_lowcmd_frames", "user_lowcmd_ignored", "posture_ignored"), 0)
        self._fallen = False

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

    # --- physics ---------------------------------------------------------------------------------

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

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps (2 ms each); firmware bookkeeping runs at the policy's 50 Hz."""
        for _ in range(n):
            with self._lock:
                if self._uc.due(self.time):
                    self._begin_user_ctrl()
                if self._steps % self._decimation == 0:
                    self._tick()
                self._loco.arm_weight = self._arm.weight
                self._stance.balancing = self._arm.weight > 0.0 or self._tasks.active
                self._stance.upper_weight = self._arm.weight
                self._stance.upper = self._tasks.command
                tau = self._ctrl.torques(self._s)
                if self._arm.weight > 0.0 and self._balanced():
                    tau = self._arm.blend(tau, self._s)
                self._data.ctrl[:] = tau
                self._forces.apply(self._data)
                mujoco.mj_step(self._g1.model, self._data)
                self._steps += 1

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
        if self._ctrl in (self._squat, self._sit):
            return self._ctrl.progress < 1.0
        return False

    def _tick(self) -> None:
        """50 Hz firmware work: velocity lease, fsm_mode, fall detector, body (temperatures, battery), remote."""
        t = self.time
        self._body.update(self._data.actuator_force[:NUM_JOINTS], self._s.dq, self._decimation * self.dt)
        self._remote_tick()
        self._tasks.update(t)
        if self._velocity_until and t >= self._velocity_until:
            self._velocity[:] = 0.0
            self._velocity_until = 0.0
        walking = self._fsm in WALKING_FSM_IDS and self._balanced()
        self._loco.command[:] = self._velocity if walking else 0.0
        self._loco.step_in_place = walking and self._balance_mode == BalanceMode.CONTINUOUS_GAIT
        pose = self.base_pose()
        self._fsm_mode = int(rules.is_dynamic(
            self._fsm, moving_command=bool(np.any(self._velocity != 0.0)),
            speed_mps=float(np.hypot(*pose.linear_velocity[:2])), yaw_rate=float(pose.angular_velocity[2]),
            transition_running=self._transition_running()))
        fallen = self._data.qpos[2] < FALL_HEIGHT_M and tilt_rad(self._data.qpos[3:7]) > FALL_TILT_RAD
        if fallen and not self._fallen:
            self.counters["falls"] += 1
            log.info("t=%.2f fall detected in fsm %d", t, self._fsm)
        self._fallen = bool(fallen)

    def _remote_tick(self) -> None:
        """L2+B pressed (both held, not held together before) damps while a service is active."""
        held = rules.remote_requests_damp(self._remote)
        if held and not self._remote_damp_held and self._service and not self._uc.engaged:
            self.counters["remote_damps"] += 1
            if self._fsm != FsmId.DAMP:
                self._enter(int(FsmId.DAMP))
            log.info("t=%.2f remote L2+B: damp", self.time)
        self._remote_damp_held = held

    # --- the body: remote, gantry, pushes --------------------------------------------------------

    def set_remote_keys(self, keys: frozenset[str]) -> None:
        """The keys held on the operator's remote from now on (the firmware looks at 50 Hz)."""
        with self._lock:
            self._remote = frozenset(keys)

    def set_gantry(self, on: bool) -> None:
        """Hang the pelvis from the gantry's band (anchored above where it is now), or unhook it."""
        with self._lock:
            self._forces.set_gantry(on, self._data)

    @property
    def gantry(self) -> bool:
        with self._lock:
            return self._forces.gantry

    def push(self, force_xy: tuple[float, float], duration_s: float) -> None:
        """Push the pelvis horizontally (N, world frame) for ``duration_s`` of sim time from now."""
        with self._lock:
            self.counters["pushes"] += 1
            self._forces.push(force_xy, duration_s, self.time)

    def set_odometry_errors(self, errors: OdomErrors, seed: int = 0) -> None:
        """A fresh estimator with these errors, starting from the truth now."""
        with self._lock:
            self._odometer = Odometer(errors, seed)

    def odometry(self) -> OdomEstimate:
        """The state estimator's output now (rt/odommodestate; the robot publishes it only while a service is
        active, the estimate itself runs on)."""
        with self._lock:
            d = self._data
            qpos, qvel = d.qpos[:7].tolist(), d.qvel[:6].tolist()  # free joint: world velocity, body rate
            return self._odometer.update(float(d.time), qpos[0:3], qpos[3:7], qvel[0:3], qvel[3:6])

    def body(self) -> BodySnapshot:
        """Motor temperatures, battery and the remote's keys as the firmware has them now."""
        with self._lock:
            return self._body.snapshot(self._remote)

    # --- sport service ---------------------------------------------------------------------------

    def sport_active(self) -> bool:
        """The sport service answers only while the motion switcher has a service selected."""
        with self._lock:
            return bool(self._service)

    def set_fsm_id(self, fsm_id: int) -> int:
        with self._lock:
            self.counters["set_fsm_requests"] += 1
            if fsm_id == FsmId.DAMP:
                self.counters["damp_requests"] += 1
            if not self._service:
                return self._log("SetFsmId", fsm_id, ERR_SERVER_API_NOT_IMPL)
            if self._uc.engaged:
                return self._ignored_in_user_ctrl("SetFsmId", fsm_id)
            code = rules.set_fsm_verdict(self._fsm, fsm_id, dynamic=self._fsm_mode == FsmMode.DYNAMIC,
                                         squatting=self._squatting)
            if code != OK:
                return self._log("SetFsmId", fsm_id, code)
            if rules.stays_as_it_is(fsm_id, self._posture()):
                self.counters["posture_ignored"] += 1
                log.info("t=%.2f SetFsmId(%d) with the robot %s: 0, nothing moves", self.time, fsm_id,
                         self._posture().value)
            elif fsm_id != self._fsm or (rules.squats_down(self._fsm, fsm_id) and self._balanced()):
                self._enter(int(fsm_id))
            return self._log("SetFsmId", fsm_id, code)

    def _posture(self) -> Posture:
        return posture_of(float(self._data.qpos[2]), self._data.qpos[3:7])

    @property
    def posture(self) -> Posture:
        """Upright, or lying on its back or front (what 702, 4 and 706 are judged on)."""
        with self._lock:
            return self._posture()

    def _enter(self, fsm: int) -> None:
        was_balanced = self._balanced()
        squat_down = rules.squats_down(self._fsm, fsm) and was_balanced
        self._fsm = fsm
        self._squatting = squat_down
        self._velocity[:] = 0.0
        self._velocity_until = 0.0
        if fsm not in STANDING_FSM_IDS:
            self._arm.weight = 0.0
        self._tasks.stop()
        if fsm == FsmId.ZERO_TORQUE:
            self._switch(self._zero)
        elif fsm == FsmId.DAMP:
            self._switch(self._damp)
        elif fsm == FsmId.SQUAT:
            self._switch(self._squat)
        elif fsm == FsmId.SIT:
            self._switch(self._sit)
        elif fsm in WALKING_FSM_IDS:  # only ever entered from a balanced stand (rules)
            self._switch(self._loco)
        elif squat_down:  # 706 from standing: StandUp2Squat, a balanced squat
            self._switch(self._squat)
        elif fsm == FsmId.LIE_TO_STAND:  # from damping, the robot lying (rules)
            self._switch(self._get_up)
        elif not was_balanced:  # stand-up ids from damp / squat / sit
            self._switch(self._stand_up)
        else:  # stand-up ids from walking or another stand: lock stand where the feet are
            self._switch(self._stance)
        self._loco.command[:] = 0.0
        self._fsm_mode = int(FsmMode.DYNAMIC if self._transition_running() else FsmMode.STATIC)

    def _log(self, call: str, arg: object, code: int) -> int:
        if code != OK:
            self.counters["refused" if code != ERR_INVALID_FSM_ID else "invalid_fsm"] += 1
        log.info("t=%.2f %s(%s) in fsm %d mode %d service %r -> %d", self.time, call, arg, self._fsm,
                 self._fsm_mode, self._service, code)
        return code

    def get_fsm_id(self) -> tuple[int, int]:
        with self._lock:
            return (OK, self._fsm) if self._service else (ERR_SERVER_API_NOT_IMPL, 0)

    def get_fsm_mode(self) -> tuple[int, int]:
        with self._lock:
            return (OK, self._fsm_mode) if self._service else (ERR_SERVER_API_NOT_IMPL, 0)

    def set_balance_mode(self, m: int) -> int:
        """0 balance stand, 1 continuous gait (keeps stepping at zero velocity while walking)."""
        with self._lock:
            if not self._service:
                return ERR_SERVER_API_NOT_IMPL
            if m not in (BalanceMode.BALANCE_STAND, BalanceMode.CONTINUOUS_GAIT):
                return ERR_SERVER_API_PARAMETER
            self._balance_mode = int(m)
            return OK

    def get_balance_mode(self) -> tuple[int, int]:
        with self._lock:
            return (OK, self._balance_mode) if self._service else (ERR_SERVER_API_NOT_IMPL, 0)

    def set_velocity(self, vx: float, vy: float, wz: float, duration_s: float = 1.0) -> int:
        """Body-frame command that lapses after ``duration_s`` of sim time (0 stops); only in walking fsm ids.

        Clamped to the speed mode's maximum and to the policy's trained range (|v| <= 1).
        """
        with self._lock:
            self.counters["velocity_requests"] += 1
            if not self._service:
                return ERR_SERVER_API_NOT_IMPL
            if self._uc.engaged:
                return self._ignored_in_user_ctrl("SetVelocity", (vx, vy, wz))
            code = rules.set_velocity_verdict(self._fsm)
            if code == OK and not self._balanced():
                code = ERR_REFUSED_IN_STATE
            if code != OK:
                return self._log("SetVelocity", (vx, vy, wz), code)
            if not all(np.isfinite((vx, vy, wz, duration_s))) or duration_s < 0:
                return ERR_SERVER_API_PARAMETER
            vmax = min(SPEED_MODE_MAX_SPEED[self._speed_mode], POLICY_MAX_COMMAND)
            self._velocity[:] = np.clip((vx, vy, wz), -vmax, vmax) if duration_s > 0 else 0.0
            self._velocity_until = self.time + duration_s if duration_s > 0 else 0.0
            self._loco.command[:] = self._velocity
            if np.any(self._velocity != 0.0):
                self._fsm_mode = int(FsmMode.DYNAMIC)
            return OK

    def set_speed_mode(self, m: int) -> int:
        with self._lock:
            if not self._service:
                return ERR_SERVER_API_NOT_IMPL
            if m not in SPEED_MODE_MAX_SPEED:
                return ERR_SERVER_API_PARAMETER
            self._speed_mode = int(m)
            return OK

    def set_stand_height(self, h: float) -> int:
        """Pelvis height of lock stand in m, reached by bending the knees; HighStand (0xFFFFFFFF) is the
        highest, LowStand (0) the lowest, anything else is clamped to :data:`STAND_HEIGHT_RANGE_M`.
        Walking ignores it (the policy has no height input). The value set is what Get reports."""
        with self._lock:
            if not self._service:
                return ERR_SERVER_API_NOT_IMPL
            if not np.isfinite(h):
                return ERR_SERVER_API_PARAMETER
            self._stand_height = float(h)
            low, high = STAND_HEIGHT_RANGE_M
            self._stance.height = high if h >= HIGH_STAND else float(np.clip(h, low, high))
            return OK

    def get_stand_height(self) -> tuple[int, float]:
        with self._lock:
            return (OK, self._stand_height) if self._service else (ERR_SERVER_API_NOT_IMPL, 0.0)

    def set_swing_height(self, h: float) -> int:
        """Stored and reported only: the policy has no swing-height input."""
        with self._lock:
            if not self._service:
                return ERR_SERVER_API_NOT_IMPL
            self._swing_height = float(h)
            return OK

    def get_swing_height(self) -> tuple[int, float]:
        with self._lock:
            return (OK, self._swing_height) if self._service else (ERR_SERVER_API_NOT_IMPL, 0.0)

    # --- arm tasks (sport SetArmTask) and the arm service ----------------------------------------------

    def _arms_free(self) -> bool:
        """Built-in arm motions play only in lock stand (the stance holds them), standing still."""
        return self._ctrl is self._stance and self._fsm_mode == FsmMode.STATIC

    def _play(self, call: str, motion_id: int, table: dict) -> int:
        if not self._service:
            return self._log(call, motion_id, ERR_SERVER_API_NOT_IMPL)
        if motion_id not in table:
            return self._log(call, motion_id, ERR_SERVER_API_PARAMETER)
        if not self._arms_free():
            return self._log(call, motion_id, ERR_REFUSED_IN_STATE)
        self._tasks.start(motion_id, table[motion_id], self.time, self._s.q[list(ARM_SDK_JOINTS)])
        return self._log(call, motion_id, OK)

    def set_arm_task(self, task_id: int) -> int:
        """sport 7106: 0 wave, 1 wave and turn, 2/3 shake hand stages (``SPORT_TASKS``)."""
        with self._lock:
            return self._play("SetArmTask", int(task_id), SPORT_TASKS)

    def execute_arm_action(self, action_id: int) -> int:
        """arm 7106 ExecuteAction: one of ``ARM_ACTIONS``; 99 (release arm) ends any motion."""
        with self._lock:
            if action_id == RELEASE_ARM and self._service:
                if self._tasks.active:  # back to the pose before the motion, then ramp out
                    self._tasks.start(RELEASE_ARM, RELEASE_MOTION, self.time, self._s.q[list(ARM_SDK_JOINTS)])
                return self._log("ExecuteAction", action_id, OK)
            return self._play("ExecuteAction", int(action_id), ARM_ACTIONS)

    def arm_action_list(self) -> dict[int, str]:
        return dict(ARM_ACTION_NAMES)

    def arm_task(self) -> tuple[int, float]:
        """(task_id, task_time) for rt/sportmodestate (see ArmTaskPlayer.report)."""
        with self._lock:
            return self._tasks.report(self.time)

    # --- motion switcher -------------------------------------------------------------------------

    def check_mode(self) -> tuple[str, str]:
        """(form, name); name "" means released (debug mode)."""
        with self._lock:
            return FORM, self._service

    def select_mode(self, name: str) -> int:
        """Select a high-level service: the robot comes back in zero torque (limp), as at boot.

        Selecting the service already selected changes nothing.
        """
        with self._lock:
            if name not in SERVICE_NAMES:
                return self._log("SelectMode", name, ERR_SERVER_API_PARAMETER)
            if name != self._service:
                self._service = name
                self._uc.end()
                self._lowlevel.clear()
                self._arm.weight = 0.0
                self._enter(int(FsmId.ZERO_TORQUE))
            return self._log("SelectMode", name, OK)

    def release_mode(self) -> int:
        """Debug mode: the sport service stops answering and the robot goes limp until LowCmds arrive."""
        with self._lock:
            if self._service:
                self._service = ""
                self._uc.end()
                self._fsm = int(FsmId.ZERO_TORQUE)
                self._squatting = False
                self._fsm_mode = int(FsmMode.STATIC)
                self._velocity[:] = 0.0
                self._arm.weight = 0.0
                self._tasks.stop()
                self._lowlevel.clear()
                self._switch(self._lowlevel)
            return self._log("ReleaseMode", "", OK)

    def get_silent(self) -> bool:
        with self._lock:
            return self._silent

    def set_silent(self, silent: bool) -> int:
        with self._lock:
            self._silent = bool(silent)
            return OK

    # --- user control (sport 7110 / 7111, rt/user_lowcmd; newer firmware) ------------------------------

    def set_user_ctrl(self, option: str, delay_s: float) -> None:
        """The firmware option and the switch's delay from now on (a switch already pending keeps its time)."""
        with self._lock:
            self._uc.option = parse_option(option)
            self._uc.delay_s = check_delay(delay_s)

    def user_ctrl_status(self) -> dict[str, object]:
        """``user_ctrl``: fsm 1000 in force; ``switching``: 7110 accepted, the delay running."""
        with self._lock:
            uc = self._uc
            return {"user_ctrl": uc.active, "switching": uc.engaged and not uc.active, "option": uc.option.value,
                    "delay_s": uc.delay_s}

    @property
    def user_ctrl_active(self) -> bool:
        """fsm 1000: the joints follow rt/user_lowcmd, rt/lowcmd is ignored."""
        with self._lock:
            return self._uc.active

    def switch_to_user_ctrl(self) -> int:
        """sport 7110: accepted per the firmware option (firmware.user_ctrl); takes effect after the delay."""
        with self._lock:
            code = switch_in_verdict(self._uc.option, self._fsm, balanced=self._balanced(), phase=self._uc.phase)
            if code == OK:
                self.counters["user_ctrl_switches"] += 1
                self._uc.begin(self.time, self._fsm)
            else:
                self.counters["user_ctrl_refused"] += 1
            return self._log("SwitchToUserCtrl", "", code)

    def switch_to_internal_ctrl(self, target: int) -> int:
        """sport 7111: in user control a built-in controller takes over from the pose it finds; otherwise (a
        switch still pending included) 0 and nothing changes."""
        with self._lock:
            if self._uc.option is UserCtrlOption.NONE and not self._uc.engaged:
                return self._log("SwitchToInternalCtrl", target, ERR_SERVER_API_NOT_IMPL)
            if target not in tuple(InternalCtrl):
                return self._log("SwitchToInternalCtrl", target, ERR_SERVER_API_PARAMETER)
            if not self._uc.active:
                return self._log("SwitchToInternalCtrl", target, OK)
            self.counters["internal_ctrl_switches"] += 1
            self._take_back(internal_target(InternalCtrl(target), self._uc.before))
            return self._log("SwitchToInternalCtrl", InternalCtrl(target).name, OK)

    def _begin_user_ctrl(self) -> None:
        """The delay is over: fsm 1000, no built-in controller, and no user command yet (limp)."""
        self._uc.activate()
        self._fsm = USER_CTRL_FSM_ID
        self._fsm_mode = int(FsmMode.STATIC)
        self._velocity[:] = 0.0
        self._velocity_until = 0.0
        self._arm.weight = 0.0
        self._tasks.stop()
        self._user.clear()  # frames count only from now on
        self._switch(self._user)
        log.info("t=%.2f user control in force (fsm %d)", self.time, self._fsm)

    def _take_back(self, fsm: int) -> None:
        """A built-in controller takes the joints as they are: damping, the policy (walking fsm ids) or lock
        stand where the feet are (stand-up ids: no stand-up motion, the robot is taken as found)."""
        self._uc.end()
        self._user.clear()
        self._fsm = fsm
        self._squatting = False
        self._loco.command[:] = 0.0
        if fsm == FsmId.DAMP:
            self._switch(self._damp)
        elif fsm in WALKING_FSM_IDS:
            self._switch(self._loco)
        else:
            self._switch(self._stance)
        self._fsm_mode = int(FsmMode.STATIC)

    def _ignored_in_user_ctrl(self, call: str, arg: object) -> int:
        """SetFsmId and Move while a switch is pending or in force: 0, and nothing happens (a conservative
        reading: a client must read the fsm back, never trust the code)."""
        self.counters["user_ctrl_ignored_calls"] += 1
        log.info("t=%.2f %s(%s) in user control: 0, nothing done", self.time, call, arg)
        return OK

    def apply_user_lowcmd(self, q: ArrayLike, dq: ArrayLike, tau: ArrayLike, kp: ArrayLike, kd: ArrayLike,
                          enabled: ArrayLike) -> bool:
        """rt/user_lowcmd (29 values each, ``enabled`` = motor mode 1): applied only in user control, held until
        the next frame. False (ignored) otherwise, the pending switch's delay included."""
        with self._lock:
            if not self._uc.active:
                self.counters["user_lowcmd_ignored"] += 1
                return False
            self.counters["user_lowcmd_frames"] += 1
            self._user.set_command(q, dq, tau, kp, kd, enabled)
            return True

    # --- streams ---------------------------------------------------------------------------------

    def apply_arm_sdk(self, q: ArrayLike, dq: ArrayLike, tau: ArrayLike, kp: ArrayLike, kd: ArrayLike,
                      weight: float) -> None:
        """rt/arm_sdk for motors 12..28 (17 values each), blend weight 0..1; ignored unless the built-in
        controller stands or walks (and then the weight drops to 0 until the next frame)."""
        with self._lock:
            if self._service and self._fsm in STANDING_FSM_IDS and self._balanced():
                self.counters["arm_sdk_frames"] += 1
                self._arm.set_command(q, dq, tau, kp, kd, weight)
            else:
                self.counters["arm_sdk_ignored"] += 1

    def apply_lowcmd(self, q: ArrayLike, dq: ArrayLike, tau: ArrayLike, kp: ArrayLike, kd: ArrayLike,
                     enabled: ArrayLike) -> None:
        """rt/lowcmd (29 values each, ``enabled`` = motor mode 1); acts only in debug mode. Held until
        the next frame, as motor drivers hold their last command."""
        with self._lock:
            if self._service:
                self.counters["lowcmd_ignored"] += 1
                return
            self.counters["lowcmd_frames"] += 1
            self._lowlevel.set_command(q, dq, tau, kp, kd, enabled)

    # --- state -----------------------------------------------------------------------------------

    def lowstate(self) -> LowStateSnapshot:
        with self._lock:
            d = self._data
            quat = d.qpos[3:7].copy()
            ga, aa = self._g1.gyro_adr, self._g1.accel_adr
            return LowStateSnapshot(
                q=self._s.q.copy(), dq=self._s.dq.copy(), tau_est=d.actuator_force[:NUM_JOINTS].copy(),
                imu_quaternion=quat, imu_gyroscope=d.sensordata[ga : ga + 3].copy(),
                imu_accelerometer=d.sensordata[aa : aa + 3].copy(), imu_rpy=quat_to_rpy(quat),
                tick=round(d.time * 1000.0), mode_machine=MODE_MACHINE_G1_29DOF, motor_mode=self._motor_mode())

    def _motor_mode(self) -> np.ndarray:
        """MotorState_.mode: 1 while a motor is enabled, as MotorCmd_.mode means it ("1:Enable, 0:Disable" in
        Unitree's low-level examples). The built-in controller keeps every motor enabled, damping and zero
        torque included (they command kp = 0, not a disabled driver); in debug mode each motor is what the
        last rt/lowcmd frame asked, disabled until one arrives; in user control, as the last rt/user_lowcmd frame."""
        if self._uc.active:
            return self._user.enabled.astype(np.uint8)
        if self._service:
            return _ALL_ENABLED
        return self._lowlevel.enabled.astype(np.uint8)

    def torso_imu(self) -> ImuSnapshot:
        """The torso IMU (rt/secondary_imu): the model's sensors on torso_link, orientation of their site."""
        with self._lock:
            d, g1, quat = self._data, self._g1, self._torso_quat
            mujoco.mju_mat2Quat(quat, d.site_xmat[g1.torso_imu_site])
            ga, aa = g1.torso_gyro_adr, g1.torso_accel_adr
            q = tuple(quat.tolist())
            return ImuSnapshot(q, tuple(d.sensordata[ga : ga + 3].tolist()), tuple(d.sensordata[aa : aa + 3].tolist()),
                               rpy_of(*q))

    def sport_state(self) -> tuple[int, int]:
        """(fsm_id, fsm_mode) for rt/sportmodestate; (0, 0) in debug mode."""
        with self._lock:
            return (self._fsm, self._fsm_mode) if self._service else (int(FsmId.ZERO_TORQUE), 0)

    def base_pose(self) -> BasePose:
        with self._lock:
            d = self._data
            rot = d.xmat[self._g1.pelvis_body].reshape(3, 3)
            return BasePose(position=d.qpos[0:3].copy(), quaternion=d.qpos[3:7].copy(),
                            linear_velocity=d.qvel[0:3].copy(), angular_velocity=rot @ d.qvel[3:6])

    @property
    def fallen(self) -> bool:
        """Pelvis below 0.4 m and tilted over (updated at 50 Hz)."""
        with self._lock:
            return self._fallen

    @property
    def fsm_id(self) -> int:
        """The controller's state, readable even in debug mode (for tests and pictures)."""
        with self._lock:
            return self._fsm

    @property
    def arm_sdk_weight(self) -> float:
        with self._lock:
            return self._arm.weight

    @property
    def walk_assist_nm(self) -> float:
        """The walking torso stabiliser's torque on the pelvis now (0 unless arm_sdk moves a walking robot)."""
        with self._lock:
            return self._loco.assist_nm

    @property
    def standing_balanced(self) -> bool:
        """The balance controller stands or walks on its own (stand-up motion finished)."""
        with self._lock:
            return self._balanced()

