"""~/lowcmd -> rt/user_lowcmd on the user_ctrl path: the same validation, forward gate and CRC as rt/lowcmd, never
a frame on rt/lowcmd, and the robot never without a command while it may be under user control.

What goes out, by situation (each frame written under the relay's worker at ``lowcmd_damping_rate_hz``):

| situation | frame |
| --- | --- |
| LOW_LEVEL, a user frame no older than ``lowcmd_timeout_s`` | the user's (written on arrival) |
| entry under way, or LOW_LEVEL before the first user frame (at most ``user_ctrl_first_frame_s`` after the entry) | the
  hand-over frame (the measured pose held) |
| LOW_LEVEL, silent, ``user_ctrl_silence: hand_back`` | a hold at the pose of that moment, until the hand-back
  (LOW_LEVEL -> IDLE by SwitchToInternalCtrl WALKRUN, or FAULT with PASSIVE when tilted) is verified |
| LOW_LEVEL, silent, ``user_ctrl_silence: damp`` | damping, as on the release path |
| link lost, dead-man released, a body check's hold | damping, as on the release path |
| a body check's hold while the entry is under way, or the way out | damping: a stiff hold is motion under a hold |
| leaving LOW_LEVEL for HIGH_LEVEL or IDLE | a hold at the pose of that moment until the robot's own controller is seen |
| e-stop, FAULT | damping until the robot is seen out of user control (fsm 1) |
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from g1_mode_manager.core.joint_commands import DAMPING, JointFrame
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.records import Outcome
from g1_mode_manager.core.user_ctrl import SilenceReaction, UserCtrlLink, hold_frame
from g1_mode_manager.relay.lowcmd import EXIT_BURST, LowCmdRelay

#: A hand-back that did not happen (refused as busy, or not verified) is tried again after this long, s.
HAND_BACK_RETRY_S = 1.0


class UserLowCmdRelay(LowCmdRelay):
    def __init__(self, *args: object, user_ctrl: UserCtrlLink, silence: SilenceReaction,
                 hand_back: Callable[[], Outcome], hold_kp: float, hold_kd: float, first_frame_s: float,
                 **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self._uc = user_ctrl
        self._silence = silence
        self._hand_back = hand_back
        self._hold_gains = (hold_kp, hold_kd)
        self._first_frame_s = first_frame_s
        self._handing_back = False  # guarded by _lock
        self._next_hand_back = float("-inf")

    def _send(self, frame: JointFrame) -> None:
        self._port.write_user_lowcmd(frame)  # type: ignore[attr-defined]

    def _hold_here(self) -> JointFrame:
        """The robot held where it is now (the previous filler if the pose is unknown)."""
        pose = self._port.joint_positions()
        return self._uc.filler if pose is None else hold_frame(pose, *self._hold_gains)

    def on_leave(self, source: Mode, target: Mode) -> None:
        """Leaving LOW_LEVEL: damping for a stop or under a body check's hold (the robot was being damped already);
        for HIGH_LEVEL or IDLE a hold where the robot is, since its own controller is about to take it back standing
        (damping would make it sink first)."""
        if source is not Mode.LOW_LEVEL:
            return
        self._watchdog.reset()
        stop = target in (Mode.EMERGENCY, Mode.FAULT) or self._gate.holding_motion()
        self._uc.filler = frame = DAMPING if stop else self._hold_here()
        sent = sum(self._write(frame, "exit_damping_frames_sent") is None for _ in range(EXIT_BURST))
        what = "damping" if frame.damping else "hold"
        self._events.log("info", "lowcmd_exit", f"leaving LOW_LEVEL for {target.name}: {sent} {what} frames sent "
                         "on rt/user_lowcmd")

    def at_exit(self) -> None:
        """The node is stopping in LOW_LEVEL: hand the robot back now (as on silence), while the worker still writes
        the hold; a robot left under user control would keep the last frame with nobody watching it."""
        if self._gate.mode is not Mode.LOW_LEVEL:
            return
        self._uc.filler = self._hold_here()
        outcome = self._hand_back()
        self._events.log("warn" if outcome.success else "error", "lowcmd_exit", f"node stopping: {outcome.message}")

    def busy(self) -> bool:
        return self._uc.live or super().busy()

    def tick(self, _dt_s: float) -> None:
        uc = self._uc
        if self._gate.allows_low_level_commands():
            if not self._link.link_ok(Mode.LOW_LEVEL) or not self._deadman():
                self._write(DAMPING, "damping_frames_sent")
                return
            age = self._watchdog.age_s()
            if age is None and self._clock() - uc.entered_at <= self._first_frame_s:
                self._write(uc.filler, "hold_frames_sent")  # entered; the user's first frame is still to come
                return
            if age is not None and age <= self._watchdog.timeout_s:
                return
            if self._silence is SilenceReaction.DAMP:
                self._write(DAMPING, "damping_frames_sent")
                return
            self._start_hand_back()
            self._write(uc.filler, "hold_frames_sent")
            return
        # a body check's hold in LOW_LEVEL, or while the robot is entering or leaving user control: never stiff
        if self._held_in_low_level() or (uc.live and self._gate.holding_motion()):
            self._write(DAMPING, "damping_frames_sent")
        elif uc.live:
            self._write(uc.filler, "hold_frames_sent")

    def _start_hand_back(self) -> None:
        with self._lock:
            now = self._clock()
            if self._handing_back or now < self._next_hand_back:
                return
            self._handing_back = True
            self._next_hand_back = now + HAND_BACK_RETRY_S
        self._uc.filler = self._hold_here()
        self._events.count("lowcmd_silence_hand_backs")
        threading.Thread(target=self._run_hand_back, name="user_ctrl_hand_back", daemon=True).start()

    def _run_hand_back(self) -> None:
        try:
            outcome = self._hand_back()
            level = "warn" if outcome.success else "error"
            self._events.log(level, "lowcmd_silence", f"~/lowcmd silent for {self._watchdog.timeout_s:g} s: "
                             f"{outcome.message}")
        finally:
            with self._lock:
                self._handing_back = False
