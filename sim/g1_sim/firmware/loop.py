"""The firmware's time: ``step`` advances the physics 2 ms at a time with the torques of the controller that holds
the joints, and at the policy's 50 Hz the firmware's own work runs: the velocity lease, fsm_mode, the fall
detector, the body (temperatures, battery) and the operator's remote (L2+B damps).
"""

from __future__ import annotations

from typing import Final

import mujoco
import numpy as np

from g1_mode_manager.protocol.fsm import WALKING_FSM_IDS, BalanceMode, FsmId
from g1_mode_manager.protocol.motors import EFFORT_LIMIT_NM, NUM_JOINTS
from g1_sim.firmware import rules
from g1_sim.firmware.core import log
from g1_sim.firmware.handover import Handover
from g1_sim.firmware.state import tilt_rad

#: Fall detector: pelvis below this and tilted more than FALL_TILT_RAD.
FALL_HEIGHT_M: Final = 0.4
FALL_TILT_RAD: Final = 0.8


class FirmwareLoop(Handover):
    """The physics step and the firmware's 50 Hz tick."""

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
                if self._runaway is not None:
                    motor, direction, until = self._runaway
                    if self.time < until:
                        tau = tau.copy()
                        tau[motor] = direction * EFFORT_LIMIT_NM[motor]
                    else:
                        self._runaway = None
                self._data.ctrl[:] = tau
                self._forces.apply(self._data)
                mujoco.mj_step(self._g1.model, self._data)
                self._steps += 1

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
