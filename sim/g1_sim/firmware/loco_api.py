"""The sport (loco) service's handlers: SetFsmId and its getters, balance mode, velocity, speed mode, stand and
swing heights. Each answers an RPC code of ``protocol.api_ids``; SetFsmId and SetVelocity while user control is
pending or in force are answered 0 and do nothing.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, Final, TypeVar

import numpy as np

from g1_mode_manager.protocol.api_ids import ERR_REFUSED_IN_STATE, ERR_SERVER_API_NOT_IMPL, ERR_SERVER_API_PARAMETER, OK
from g1_mode_manager.protocol.fsm import SPEED_MODE_MAX_SPEED, BalanceMode, FsmId, FsmMode
from g1_sim.firmware import rules
from g1_sim.firmware.core import log
from g1_sim.firmware.handover import Handover
from g1_sim.physics.model import STAND_HEIGHT_RANGE_M

#: The policy was trained on commands in [-1, 1] (ONNX metadata), so faster requests are clamped.
POLICY_MAX_COMMAND: Final = 1.0
#: SetStandHeight's HighStand value (LowStand is 0): a uint32 all ones, meaning "the highest".
HIGH_STAND: Final = 0xFFFFFFFF

T = TypeVar("T")


def _while_selected(call: Callable[..., int]) -> Callable[..., int]:
    """A setter of the sport service, which answers only while the motion switcher has a service selected (not
    implemented, and nothing done, otherwise); it runs under the firmware's lock."""

    @functools.wraps(call)
    def answered(self: LocoApi, *args: Any) -> int:
        with self._lock:
            return call(self, *args) if self._service else ERR_SERVER_API_NOT_IMPL

    return answered


class LocoApi(Handover):
    """The sport service's calls on the built-in controller."""

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

    def get_fsm_id(self) -> tuple[int, int]:
        return self._get(lambda: self._fsm, 0)

    def get_fsm_mode(self) -> tuple[int, int]:
        return self._get(lambda: self._fsm_mode, 0)

    @_while_selected
    def set_balance_mode(self, m: int) -> int:
        """0 balance stand, 1 continuous gait (keeps stepping at zero velocity while walking)."""
        if m not in (BalanceMode.BALANCE_STAND, BalanceMode.CONTINUOUS_GAIT):
            return ERR_SERVER_API_PARAMETER
        self._balance_mode = int(m)
        return OK

    def get_balance_mode(self) -> tuple[int, int]:
        return self._get(lambda: self._balance_mode, 0)

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

    @_while_selected
    def set_speed_mode(self, m: int) -> int:
        if m not in SPEED_MODE_MAX_SPEED:
            return ERR_SERVER_API_PARAMETER
        self._speed_mode = int(m)
        return OK

    @_while_selected
    def set_stand_height(self, h: float) -> int:
        """Pelvis height of lock stand in m, reached by bending the knees; HighStand (0xFFFFFFFF) is the
        highest, LowStand (0) the lowest, anything else is clamped to :data:`STAND_HEIGHT_RANGE_M`.
        Walking ignores it (the policy has no height input). The value set is what Get reports."""
        if not np.isfinite(h):
            return ERR_SERVER_API_PARAMETER
        self._stand_height = float(h)
        low, high = STAND_HEIGHT_RANGE_M
        self._stance.height = high if h >= HIGH_STAND else float(np.clip(h, low, high))
        return OK

    def get_stand_height(self) -> tuple[int, float]:
        return self._get(lambda: self._stand_height, 0.0)

    @_while_selected
    def set_swing_height(self, h: float) -> int:
        """Stored and reported only: the policy has no swing-height input."""
        self._swing_height = float(h)
        return OK

    def get_swing_height(self) -> tuple[int, float]:
        return self._get(lambda: self._swing_height, 0.0)

    def _get(self, value: Callable[[], T], unanswered: T) -> tuple[int, T]:
        """A getter's answer: the value read under the lock while a service is selected, else not implemented."""
        with self._lock:
            return (OK, value()) if self._service else (ERR_SERVER_API_NOT_IMPL, unanswered)

    def _ignored_in_user_ctrl(self, call: str, arg: object) -> int:
        """SetFsmId and Move while a switch is pending or in force: 0, and nothing happens (a conservative
        reading: a client must read the fsm back, never trust the code)."""
        self.counters["user_ctrl_ignored_calls"] += 1
        log.info("t=%.2f %s(%s) in user control: 0, nothing done", self.time, call, arg)
        return OK
