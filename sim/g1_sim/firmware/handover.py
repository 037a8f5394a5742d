"""Which built-in controller holds the joints after a change of state: an fsm id entered (SetFsmId, the remote's
L2+B, SelectMode), user control in force (7110 after its delay: rt/user_lowcmd's own controller), the joints taken
back (7111). The rules that allow each change are firmware.rules' and firmware.user_ctrl's.
"""

from __future__ import annotations

from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, USER_CTRL_FSM_ID, WALKING_FSM_IDS, FsmId, FsmMode
from g1_sim.firmware import rules
from g1_sim.firmware.core import FirmwareCore, log


class Handover(FirmwareCore):
    """Hands the joints to the controller of the state entered."""

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
        elif squat_down:  # 706 from standing: StandUp2Squat, down into the folded squat (physics/fold.py)
            self._switch(self._fold)
        elif fsm == FsmId.LIE_TO_STAND:  # from damping, the robot lying (rules)
            self._switch(self._get_up)
        elif not was_balanced:  # stand-up ids from damp / squat / sit
            self._switch(self._stand_up)
        else:  # stand-up ids from walking or another stand: lock stand where the feet are
            self._switch(self._stance)
        self._loco.command[:] = 0.0
        self._fsm_mode = int(FsmMode.DYNAMIC if self._transition_running() else FsmMode.STATIC)

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
