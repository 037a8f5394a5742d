"""Built-in arm motions: the sport service's SetArmTask and the arm service's actions (firmware.arm_tasks plays
them), started only in lock stand, standing still.
"""

from __future__ import annotations

from g1_mode_manager.protocol.api_ids import ERR_REFUSED_IN_STATE, ERR_SERVER_API_NOT_IMPL, ERR_SERVER_API_PARAMETER, OK
from g1_mode_manager.protocol.fsm import FsmMode
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS
from g1_sim.firmware.arm_tasks import ARM_ACTION_NAMES, ARM_ACTIONS, RELEASE_ARM, RELEASE_MOTION, SPORT_TASKS
from g1_sim.firmware.core import FirmwareCore


class ArmService(FirmwareCore):
    """SetArmTask and the arm service's ExecuteAction."""

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
