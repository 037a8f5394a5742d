"""The supervision: keeps EMERGENCY true on the robot, and checks every other mode against the robot.

Called periodically by the node (about 10 Hz) with the last rt/sportmodestate:
- In EMERGENCY and FAULT a robot seen out of damping (rt/sportmodestate, a periodic CheckMode + GetFsmId, a call
  that landed after the e-stop began, a sequence that did not verify) is re-selected and re-damped at
  once, with an alarm; nothing leaves EMERGENCY, and FAULT only by clear_fault.
- In HIGH_LEVEL and LOW_LEVEL a CheckMode every ``belief_period_s`` must agree with the mode; otherwise
  forwarding stops (``robot_mismatch``) until an operator requests a mode again.
"""

from __future__ import annotations

from collections.abc import Callable

from g1_mode_manager.core.estop_policy import EstopTiming
from g1_mode_manager.core.joint_commands import DAMPING
from g1_mode_manager.core.machine.estop import Estop, verdict
from g1_mode_manager.core.machine.gate import ForwardGate
from g1_mode_manager.core.machine.state import MachineState
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import ModePort, RobotError
from g1_mode_manager.core.service_steps import StepTimeoutError
from g1_mode_manager.protocol.fsm import USER_CTRL_FSM_ID, FsmId

#: rt/sportmodestate read within this long after the robot was verified damped is no evidence against it
#: (the newest sample may predate the Damp: the robot publishes it faster than the supervision reads it), s.
STATE_SETTLE_S = 0.25


class Supervisor:
    def __init__(self, state: MachineState, gate: ForwardGate, estop: Estop, port: ModePort,
                 timing: EstopTiming) -> None:
        self._state = state
        self._gate = gate
        self._estop = estop
        self._port = port
        self._timing = timing
        #: FAULT's entry (set by the facade): where a robot found under user control outside LOW_LEVEL goes.
        self.fault: Callable[[tuple[str, ...]], bool] = lambda _faults: False

    def supervise(self, fsm_id: int | None, state_age_s: float | None) -> None:
        state = self._state
        now = state.clock()
        with state.lock:
            mode, connected, transition = state.mode, state.connected, state.inflight is not None
        if not connected and mode is not Mode.EMERGENCY:
            return
        if mode in (Mode.EMERGENCY, Mode.FAULT):
            self._keep_damped(now, mode, fsm_id, state_age_s)
            return
        if transition:
            return
        if mode in (Mode.IDLE, Mode.HIGH_LEVEL) and self._late_switch(fsm_id, state_age_s):
            return
        if mode in (Mode.HIGH_LEVEL, Mode.LOW_LEVEL):
            self._check_belief(now, mode)

    def _late_switch(self, fsm_id: int | None, state_age_s: float | None) -> bool:
        """user_ctrl path: fsm 1000 outside LOW_LEVEL is a SwitchToUserCtrl that took effect after the node gave
        up on it (the firmware does not cancel an accepted switch): nobody commands the joints, so FAULT, whose
        sequence damps with PASSIVE. True if FAULT was entered."""
        user_ctrl = self._estop.user_ctrl
        if user_ctrl is None or fsm_id != USER_CTRL_FSM_ID or state_age_s is None \
                or state_age_s > self._timing.state_fresh_s:
            return False
        if self._state.clock() - state_age_s <= user_ctrl.link.left_at + STATE_SETTLE_S:
            return False  # a sample sent before the hand-back that was just verified
        user_ctrl.link.mark_live(DAMPING)
        return self.fault(("user control outside LOW_LEVEL: the robot shows fsm 1000 (a switch that landed late)",))

    # --- EMERGENCY and FAULT ---------------------------------------------------------------------
    def _keep_damped(self, now: float, mode: Mode, fsm_id: int | None, state_age_s: float | None) -> None:
        if self._estop.running():
            return
        state, timing = self._state, self._timing
        with state.lock:
            late, state.late_landing = state.late_landing, False
            confirmed = state.damp_confirmed
            verify_due = now >= state.next_verify
            if verify_due:
                state.next_verify = now + timing.verify_period_s
            # a sample read just after a verification may have been sent before the Damp took effect
            settled = now - state.verified_at > STATE_SETTLE_S
        fresh = fsm_id is not None and state_age_s is not None and state_age_s <= timing.state_fresh_s and settled
        user_ctrl = self._estop.user_ctrl
        if user_ctrl is not None and fresh and fsm_id == USER_CTRL_FSM_ID:
            user_ctrl.link.mark_live(DAMPING)  # a late switch: damping frames again, PASSIVE in the sequence
        why = ""
        if late:
            why = "a robot call landed after the e-stop began"
        elif fresh and fsm_id != FsmId.DAMP:
            why = f"robot left damping: rt/sportmodestate says fsm {fsm_id}"
        elif not confirmed:
            why = "the last e-stop sequence did not verify the robot damped"
        elif verify_due:
            why = self._verify_now()
        if not why or not self._estop.claim_runner():
            return
        with state.lock:
            state.reasserts += 1
            state.damp_confirmed = False
            state.version += 1
        state.alarm(f"{mode.name} re-asserted: {why}")
        self._estop.fire_damp_no_reply()
        run = self._estop.run_sequences()
        if run.why is not None:
            state.alarm(f"{mode.name} re-assert incomplete: {run.why}")

    def _verify_now(self) -> str:
        """'' if CheckMode names a service and GetFsmId is Damp, else why not."""
        try:
            return verdict(self._estop.calls())
        except (RobotError, StepTimeoutError) as exc:
            return f"verification failed: {exc}"
        except Exception as exc:
            return f"verification failed: unexpected {type(exc).__name__}: {exc}"

    # --- every other mode ------------------------------------------------------------------------
    def _check_belief(self, now: float, mode: Mode) -> None:
        state = self._state
        with state.lock:
            if now < state.next_belief or state.mismatch:
                return
            state.next_belief = now + self._timing.belief_period_s
            version = state.version
        user_ctrl = self._estop.user_ctrl is not None
        try:
            name = self._port.check_mode(timeout_s=self._timing.call_s)
            # on the user_ctrl path the service stays active in LOW_LEVEL and the robot must show fsm 1000
            fsm = self._port.get_fsm_id(timeout_s=self._timing.call_s) if user_ctrl and mode is Mode.LOW_LEVEL \
                and name else None
        except Exception:  # a lost answer is link health's business, not a mismatch
            return
        if user_ctrl and mode is Mode.LOW_LEVEL:
            if name and fsm == USER_CTRL_FSM_ID:
                return
            what = f"GetFsmId says {fsm}, not 1000 (user control)" if name else \
                "CheckMode says the high-level service released"
            self.report_mismatch(f"robot does not match LOW_LEVEL: {what}", version)
            return
        if bool(name) == (mode is Mode.HIGH_LEVEL):
            return
        what = f"service {name!r} active" if name else "the high-level service released"
        self.report_mismatch(f"robot does not match {mode.name}: CheckMode says {what}", version)

    def report_mismatch(self, reason: str, version: int | None = None) -> None:
        """The robot no longer matches the mode (another program, a reboot): stop forwarding until an
        operator requests a mode again. Ignored in EMERGENCY and FAULT (supervision handles it there), and if
        the state changed since ``version`` (the evidence is then stale)."""
        state = self._state
        with self._gate.lock, state.lock:
            if state.mode in (Mode.EMERGENCY, Mode.FAULT, Mode.UNINITIALIZED) or state.inflight is not None or state.mismatch:
                return
            if version is not None and version != state.version:
                return
            state.mismatch = reason
            state.service_known = False
            state.last_error = reason
            state.version += 1
        state.alarm(f"{reason}; forwarding stopped until a mode is requested again")
        state.notify()
