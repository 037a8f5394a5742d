"""User control (sport 7110 / 7111; newer firmware): the switch's handlers and its status. The rules are
firmware.user_ctrl's; the joints change hands in firmware.handover.
"""

from __future__ import annotations

from g1_mode_manager.protocol.api_ids import ERR_SERVER_API_NOT_IMPL, ERR_SERVER_API_PARAMETER, OK
from g1_mode_manager.protocol.fsm import InternalCtrl
from g1_sim.firmware.handover import Handover
from g1_sim.firmware.user_ctrl import UserCtrlOption, check_delay, internal_target, parse_option, switch_in_verdict


class UserCtrlService(Handover):
    """SwitchToUserCtrl, SwitchToInternalCtrl and the firmware option they follow."""

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
