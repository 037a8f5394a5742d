"""The user_ctrl path's robot steps, run by the transition runner and the e-stop; every one verified on the robot.

- ``enter``: the service must be active (user control is a sport api); a hand-over frame at the measured pose on
  rt/user_lowcmd (and, through ``link``, continuously from then on); SwitchToUserCtrl; GetFsmId must show 1000
  within ``switch_timeout_s`` before the mode commits and a single user frame passes. 3203 or no answer: refused
  with nothing changed. Not seen: SwitchToInternalCtrl(LAST) and refused with what the robot showed.
- ``hand_back``: SwitchToInternalCtrl(LAST or WALKRUN), then another fsm than 1000 seen (WALKRUN: a standing or
  walking one). WALKRUN only when upright by the template's limits; otherwise NotUpright (the caller enters FAULT,
  whose sequence sends PASSIVE).
- ``before_damp``: the e-stop's and FAULT's SwitchToInternalCtrl(PASSIVE) while the robot may be under user
  control (SetFsmId does nothing there).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from g1_mode_manager.core.joint_commands import DAMPING
from g1_mode_manager.core.port import RobotError
from g1_mode_manager.core.preemption import Preempted, RunPort
from g1_mode_manager.core.user_ctrl import (
    HAND_BACK_ATTITUDE_S,
    LATE_SWITCH_WAIT_S,
    UNSUPPORTED,
    NotUpright,
    UserCtrlConfig,
    UserCtrlLink,
    UserCtrlPort,
    UserCtrlRefused,
    hold_frame,
    upright,
)
from g1_mode_manager.protocol.api_ids import ERR_SERVER_API_NOT_IMPL
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, USER_CTRL_FSM_ID, InternalCtrl


class UserCtrlSteps:
    def __init__(self, port: UserCtrlPort, link: UserCtrlLink, config: UserCtrlConfig, *,
                 clock: Callable[[], float]) -> None:
        self.port = port
        self.link = link
        self.config = config
        self._clock = clock

    # --- into LOW_LEVEL ----------------------------------------------------------------------------
    def enter(self, calls: RunPort) -> str:
        """Switch the robot to user control; returns what it showed. Raises UserCtrlRefused (nothing changed on
        the robot, or handed back), RobotError, Preempted."""
        if not calls.check_mode():
            raise UserCtrlRefused("the high-level service is released (debug mode): user control needs it; request "
                                  "HIGH_LEVEL first, or use low_level_path: release")
        before = calls.get_fsm_id()
        self._wait_for_rest(calls)
        pose = self._measured_pose(calls)
        if pose is None:
            raise UserCtrlRefused("no measured pose (rt/lowstate not received): nothing to hold the robot at")
        hold = hold_frame(pose, self.config.hold_kp, self.config.hold_kd)
        # from here the lowcmd relay repeats it until a user frame passes; an e-stop that preempted this entry
        # while the pose was measured must not find a stiff hold begun behind it
        if not self.link.begin(hold, calls.preempted):
            raise Preempted("the hand-over frame")
        self.port.write_user_lowcmd(self.link.filler)  # before the switch: the robot has a command from its first instant
        self.link.switch_sent()
        try:
            calls.switch_to_user_ctrl()
        except Preempted:  # answered after an e-stop began: the robot may still switch (the e-stop waits for it)
            answered = calls.user_ctrl_switch_answered  # False: preempted before it was sent
            self.link.switch_answered(max(self.config.switch_timeout_s, LATE_SWITCH_WAIT_S) if answered
                                      else self.config.switch_timeout_s)
            raise
        except RobotError as exc:
            if exc.code == ERR_SERVER_API_NOT_IMPL:
                self.link.forget()
                raise UserCtrlRefused(UNSUPPORTED) from None
            if exc.not_sent:
                self.link.forget()
                raise UserCtrlRefused(f"SwitchToUserCtrl not sent ({exc}); nothing changed") from None
            if not exc.maybe_delivered:  # refused by the robot (a precondition): nothing switched
                self.link.forget()
                raise UserCtrlRefused(f"the robot refused SwitchToUserCtrl ({exc}) at fsm {before}; nothing "
                                      "changed") from None
            # no answer: it may have switched, or still switch; look for as long as an answered one may take
            self.link.switch_answered(self.config.switch_timeout_s)
            seen = self._wait_fsm(calls, lambda fsm: fsm == USER_CTRL_FSM_ID)
            if seen == USER_CTRL_FSM_ID:
                self._hand_back_or_say(calls, InternalCtrl.LAST)
                raise UserCtrlRefused(f"SwitchToUserCtrl unanswered but the robot showed fsm 1000: handed back "
                                      f"(SwitchToInternalCtrl LAST); {UNSUPPORTED}") from None
            self.link.forget()
            raise UserCtrlRefused(f"{UNSUPPORTED} (SwitchToUserCtrl not answered; the robot shows fsm {seen})") from None
        self.link.switch_answered(self.config.switch_timeout_s)
        seen = self._wait_fsm(calls, lambda fsm: fsm == USER_CTRL_FSM_ID)
        if seen != USER_CTRL_FSM_ID:
            shown = self._hand_back_or_say(calls, InternalCtrl.LAST)
            raise UserCtrlRefused(f"SwitchToUserCtrl answered 0 but the robot showed fsm {seen}, not 1000, for "
                                  f"{self.config.switch_timeout_s:g} s: SwitchToInternalCtrl(LAST) sent; {shown}")
        self.link.entered()
        return f"fsm {before} -> 1000 seen"

    def _wait_for_rest(self, calls: RunPort) -> None:
        """A stiff hold of a pose taken mid-step falls over: wait until every joint is slower than
        rest_speed_rad_s on three samples in a row (a walk-run controller coming to rest after StopMove takes
        about a second), at most rest_timeout_s; then refuse, nothing changed."""
        deadline = self._clock() + self.config.rest_timeout_s
        still = 0
        speed = None
        while still < 3:
            speed = self.port.joint_speed_max()
            still = still + 1 if speed is not None and speed <= self.config.rest_speed_rad_s else 0
            if still < 3:
                if self._clock() >= deadline:
                    what = "no fresh rt/lowstate" if speed is None else f"a joint at {speed:.2f} rad/s"
                    raise UserCtrlRefused(f"the robot is not at rest after {self.config.rest_timeout_s:g} s ({what} > "
                                          f"{self.config.rest_speed_rad_s:g}): nothing changed; stop it, then request "
                                          "LOW_LEVEL again")
                calls.sleep(self.config.poll_interval_s)

    def _measured_pose(self, calls: RunPort) -> Sequence[float] | None:
        """The joints' measured pose; rt/lowstate may have been subscribed only for this entry (an idle HIGH_LEVEL
        does not receive it), so wait for its first sample, at most switch_timeout_s."""
        deadline = self._clock() + self.config.switch_timeout_s
        while (pose := self.port.joint_positions()) is None and self._clock() < deadline:
            calls.sleep(self.config.poll_interval_s)
        return pose

    def _fresh_attitude(self, calls: RunPort) -> tuple[float, float] | None:
        """The robot's roll and pitch from a sample at most HAND_BACK_ATTITUDE_S old, waiting at most
        switch_timeout_s for one: a node starved of the CPU may find its newest one old while the hold frames keep
        the robot up, and an attitude that is only unknown is no reason to damp a standing robot. Still unknown
        after that: blind (not upright)."""
        deadline = self._clock() + self.config.switch_timeout_s
        while (attitude := self.port.attitude(HAND_BACK_ATTITUDE_S)) is None and self._clock() < deadline:
            calls.sleep(self.config.poll_interval_s)
        return attitude

    # --- out of LOW_LEVEL --------------------------------------------------------------------------
    def hand_back(self, calls: RunPort, target: InternalCtrl) -> str:
        """SwitchToInternalCtrl(target) and the robot seen out of user control. WALKRUN only when upright."""
        if target is InternalCtrl.WALKRUN:
            attitude = self._fresh_attitude(calls)
            if not upright(attitude):
                what = "unknown (no fresh rt/lowstate)" if attitude is None else \
                    f"roll {attitude[0]:.2f} rad, pitch {attitude[1]:.2f} rad"
                raise NotUpright(f"not upright for the walk-run controller: {what} (limits |roll| <= 1.0, "
                                 "|pitch| <= 0.8 rad)")
        calls.switch_to_internal_ctrl(target)
        want = (lambda fsm: fsm in STANDING_FSM_IDS) if target is InternalCtrl.WALKRUN else \
            (lambda fsm: fsm != USER_CTRL_FSM_ID)
        seen = self._wait_fsm(calls, want)
        if not want(seen):
            raise RobotError("SwitchToInternalCtrl", 0, f"answered 0 but the robot showed fsm {seen} for "
                             f"{self.config.switch_timeout_s:g} s")
        self.link.left()
        return f"SwitchToInternalCtrl({target.name}): fsm {seen} seen"

    def _hand_back_or_say(self, calls: RunPort, target: InternalCtrl) -> str:
        """A refused entry's way back; returns what the robot showed (never raises a RobotError)."""
        try:
            return self.hand_back(calls, target)
        except RobotError as exc:
            return f"hand-back not verified: {exc}"

    def _wait_fsm(self, calls: RunPort, done: Callable[[int], bool]) -> int:
        deadline = self._clock() + self.config.switch_timeout_s
        while True:
            seen = calls.get_fsm_id()
            if done(seen) or self._clock() >= deadline:
                return seen
            calls.sleep(self.config.poll_interval_s)

    # --- the e-stop's and FAULT's part ---------------------------------------------------------------
    def before_damp(self, calls: RunPort, notes: list[str]) -> None:
        """SwitchToInternalCtrl(PASSIVE) while the robot may be under user control; a failure is a note (the
        Damp and the verification that follow decide). An accepted SwitchToUserCtrl whose fsm 1000 has not shown
        yet may still take effect after a Damp: wait for it (bounded by switch_timeout_s after its answer, and by
        the e-stop's own budget) so the verification that follows is not overtaken by it."""
        if not self.link.live:
            return
        while self.link.switch_pending_s() > 0.0:
            if calls.get_fsm_id() == USER_CTRL_FSM_ID:
                self.link.entered()
                break
            calls.sleep(self.config.poll_interval_s)
        try:
            calls.switch_to_internal_ctrl(InternalCtrl.PASSIVE)
        except RobotError as exc:
            notes.append(f"SwitchToInternalCtrl(PASSIVE) failed: {exc}")

    def after_verdict(self, fsm: int | None, damped: bool) -> None:
        """The e-stop's verification saw ``fsm``: out of user control once damped, live again if it shows 1000."""
        if damped:
            self.link.left()
        elif fsm == USER_CTRL_FSM_ID:
            self.link.mark_live(DAMPING)
