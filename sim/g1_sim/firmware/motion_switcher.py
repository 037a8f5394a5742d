"""The motion switcher's handlers: which high-level service is selected (CheckMode, SelectMode), debug mode
(ReleaseMode: limp until rt/lowcmd frames arrive) and the silent flag. The sport service answers only while a
service is selected.
"""

from __future__ import annotations

from typing import Final

from g1_mode_manager.protocol.api_ids import ERR_SERVER_API_PARAMETER, OK
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from g1_sim.firmware.core import SERVICE_NAMES
from g1_sim.firmware.handover import Handover

#: CheckMode's form, answered with the service's name.
FORM: Final = "0"


class MotionSwitcher(Handover):
    """CheckMode, SelectMode, ReleaseMode and the silent flag."""

    def sport_active(self) -> bool:
        """The sport service answers only while the motion switcher has a service selected."""
        with self._lock:
            return bool(self._service)

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
