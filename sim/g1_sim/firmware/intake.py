"""The low-level command intake: rt/arm_sdk, rt/lowcmd and rt/user_lowcmd frames, each taken only in the state its
topic is for (counted as taken or ignored) and held until the next frame, as motor drivers hold their last command.
"""

from __future__ import annotations

from numpy.typing import ArrayLike

from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS
from g1_sim.firmware.core import FirmwareCore


class CommandIntake(FirmwareCore):
    """The frames of the three command streams."""

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
