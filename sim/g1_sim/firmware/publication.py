"""What the robot publishes and reports: rt/lowstate's snapshot with the motors' mode, the torso IMU,
rt/sportmodestate's fsm, the estimator's odometry (firmware.odometry: the truth with drift and noise), the body
(temperatures, battery, the remote's keys), and the readings tests and pictures take (posture, a fall, a
balanced stand, the arm_sdk weight, the walking stabiliser's torque).
"""

from __future__ import annotations

from typing import Final

import mujoco
import numpy as np

from g1_mode_manager.protocol.fsm import FsmId
from g1_mode_manager.protocol.motors import MODE_MACHINE_G1_29DOF, NUM_JOINTS
from g1_sim.firmware.core import FirmwareCore
from g1_sim.firmware.odometry import OdomErrors, OdomEstimate, Odometer
from g1_sim.firmware.posture import Posture
from g1_sim.firmware.state import BodySnapshot, ImuSnapshot, LowStateSnapshot, quat_to_rpy, rpy_of

_ALL_ENABLED: Final = np.ones(NUM_JOINTS, dtype=np.uint8)
_ALL_ENABLED.flags.writeable = False


class StatePublication(FirmwareCore):
    """The robot's state as its streams and reports give it."""

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

    @property
    def posture(self) -> Posture:
        """Upright, or lying on its back or front (what 702, 4 and 706 are judged on)."""
        with self._lock:
            return self._posture()

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
