"""The fake G1's user control (SwitchToUserCtrl / SwitchToInternalCtrl, rt/user_lowcmd), as the contract with the
sim describes the firmware: a firmware option, a switch that shows fsm 1000 only after some GetFsmId polls, user
frames logged with what the robot was doing when they arrived."""

from __future__ import annotations

import threading
from collections.abc import Sequence

from fakes.fake_robot import FakeRobot
from g1_mode_manager.core.port import MotorCommand, RobotError
from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, USER_CTRL_FSM_ID, FsmId, InternalCtrl

REFUSED_IN_STATE = api_ids.ERR_REFUSED_IN_STATE


class UserCtrlRobot(FakeRobot):
    """``firmware``: none | from_damp | from_walkrun | either. ``standing_fsm``: what a standing robot shows."""

    def __init__(self, *args, firmware: str = "either", **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._uc_lock = threading.Lock()
        self.firmware = firmware
        self.user_ctrl = False
        self.switch_polls = 1  # GetFsmId answers before 1000 shows after an accepted 7110 (the switch delay)
        self.switch_never_shows = False  # 7110 answers 0 and the robot never shows 1000
        self._pending = -1  # polls left until the accepted switch takes effect; -1: none pending
        self.standing_fsm = int(FsmId.START)
        self.fsm_before = int(FsmId.START)
        self.walkrun_shows = int(FsmId.START)  # the fsm WALKRUN hands back into
        self.user_frames: list[tuple[bool, tuple[MotorCommand, ...]]] = []  # (in user control, frame)
        self.internal_ctrl_calls: list[InternalCtrl] = []
        self.pose: list[float] | None = [0.0] * 29
        self.roll_pitch: tuple[float, float] | None = (0.0, 0.0)
        self.joint_speed: float | None = 0.0  # largest |dq|, rad/s: at rest

    def _fsm(self) -> int:
        if self.user_ctrl:
            return USER_CTRL_FSM_ID
        return int(FsmId.DAMP) if self.damped else self.standing_fsm

    # --- the sport service -------------------------------------------------------------------------
    def get_fsm_id(self, timeout_s: float | None = None) -> int:
        fsm = super().get_fsm_id(timeout_s)  # logs, faults, 3203 in debug mode
        with self._uc_lock:
            if self._pending > 0:
                self._pending -= 1
            elif self._pending == 0:
                self._pending = -1
                self.user_ctrl = True
            return USER_CTRL_FSM_ID if self.user_ctrl else fsm if fsm == 1 else self.standing_fsm

    def switch_to_user_ctrl(self, timeout_s: float | None = None) -> None:
        call = self._enter("switch_to_user_ctrl", ())
        with self._uc_lock:
            if self.firmware == "none" or not self.service:
                call.result = "3203"
                raise RobotError("SwitchToUserCtrl", api_ids.ERR_SERVER_API_NOT_IMPL, "not implemented")
            fsm = self._fsm()
            ok = (self.firmware in ("either", "from_damp") and fsm == 1) or \
                (self.firmware in ("either", "from_walkrun") and fsm in STANDING_FSM_IDS)
            if not ok:
                call.result = "refused"
                raise RobotError("SwitchToUserCtrl", REFUSED_IN_STATE, f"not from fsm {fsm}")
            if not self.switch_never_shows:
                self.fsm_before = fsm
                self._pending = self.switch_polls

    def switch_to_internal_ctrl(self, target: InternalCtrl, timeout_s: float | None = None) -> None:
        self._enter("switch_to_internal_ctrl", (int(target),))
        with self._uc_lock:
            if self.firmware == "none":
                raise RobotError("SwitchToInternalCtrl", api_ids.ERR_SERVER_API_NOT_IMPL, "not implemented")
            self.internal_ctrl_calls.append(InternalCtrl(target))
            if not self.user_ctrl:
                return  # outside user control: answers 0 and does nothing
            self.user_ctrl = False
            if target is InternalCtrl.PASSIVE or (target is InternalCtrl.LAST and self.fsm_before == 1):
                self.damped = True
            else:
                self.damped = False
                self.standing_fsm = self.walkrun_shows if target is InternalCtrl.WALKRUN else self.fsm_before

    def damp(self, timeout_s: float | None = None) -> None:
        if self.user_ctrl:  # answers 0 and does nothing under user control
            self._enter("damp", ())
            return
        super().damp(timeout_s)

    def damp_no_reply(self) -> None:
        if self.user_ctrl:
            self._enter("damp_no_reply", ())
            return
        super().damp_no_reply()

    # --- streams -----------------------------------------------------------------------------------
    def write_user_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        assert len(commands) == 29
        with self._uc_lock:
            self.user_frames.append((self.user_ctrl, tuple(commands)))

    def joint_positions(self) -> Sequence[float] | None:
        return self.pose

    def attitude(self, max_age_s: float) -> tuple[float, float] | None:
        return self.roll_pitch

    def joint_speed_max(self) -> float | None:
        return self.joint_speed
