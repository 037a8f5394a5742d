"""ModeMachine: the one object the node, the relays and the tests hold; it only wires and delegates.

Beside it, one file per guarantee: ``state.py`` (the fields and their lock, the listeners), ``gate.py``
(the forward gate and the calls in flight), ``runner.py`` (transitions), ``estop.py`` (the e-stop),
``supervisor.py`` (EMERGENCY and FAULT kept true, the robot checked against the mode), ``fault.py`` (FAULT,
holds and the operator's clear).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import AbstractContextManager

from g1_mode_manager.core import modes
from g1_mode_manager.core.estop_policy import EstopTiming
from g1_mode_manager.core.machine.estop import Estop
from g1_mode_manager.core.machine.fault import FaultStop
from g1_mode_manager.core.machine.gate import ForwardDecision, ForwardGate
from g1_mode_manager.core.machine.runner import TransitionRunner
from g1_mode_manager.core.machine.state import AlarmListener, LeaveListener, MachineState
from g1_mode_manager.core.machine.supervisor import Supervisor
from g1_mode_manager.core.machine.user_ctrl_steps import UserCtrlSteps
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import ModePort
from g1_mode_manager.core.records import MachineStatus, Outcome, TransitionRecord
from g1_mode_manager.core.transitions import Trigger
from g1_mode_manager.core.user_ctrl import LowLevelPath, UserCtrlConfig, UserCtrlLink, UserCtrlPort


class ModeMachine:
    """Holds the control mode of the robot and changes it only through the transition table."""

    def __init__(
        self,
        port: ModePort,
        *,
        release_timeout_s: float = 5.0,
        poll_interval_s: float = 0.1,
        select_timeout_s: float = 10.0,
        estop_timing: EstopTiming | None = None,
        on_record: Callable[[TransitionRecord], None] | None = None,
        on_change: Callable[[MachineStatus], None] | None = None,
        on_alarm: AlarmListener | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        history_size: int = 100,
        user_ctrl: UserCtrlConfig | None = None,
    ) -> None:
        """``user_ctrl``: LOW_LEVEL by the firmware's user control (``port`` must then be a UserCtrlPort too);
        None: LOW_LEVEL by ReleaseMode (low_level_path release)."""
        self._timing = timing = estop_timing or EstopTiming()
        self._state = MachineState(clock=clock, on_record=on_record, on_change=on_change, on_alarm=on_alarm,
                                   history_size=history_size)
        self._gate = ForwardGate(self._state)
        self._runner = TransitionRunner(self._state, self._gate, port, release_timeout_s=release_timeout_s,
                                        select_timeout_s=select_timeout_s, poll_interval_s=poll_interval_s,
                                        belief_period_s=timing.belief_period_s, sleep=sleep)
        self._estop = Estop(self._state, self._gate, port, timing, poll_interval_s=poll_interval_s, sleep=sleep)
        self._supervisor = Supervisor(self._state, self._gate, self._estop, port, timing)
        self._fault = FaultStop(self._state, self._gate, self._estop)
        self.user_ctrl_link: UserCtrlLink | None = None
        if user_ctrl is not None:
            if not isinstance(port, UserCtrlPort):
                raise TypeError("low_level_path user_ctrl needs a robot port with SwitchToUserCtrl (UserCtrlPort)")
            self.user_ctrl_link = UserCtrlLink(clock)
            steps = UserCtrlSteps(port, self.user_ctrl_link, user_ctrl, clock=clock)
            self._runner.user_ctrl = self._estop.user_ctrl = steps
        self._runner.fault = self._supervisor.fault = self._fault.enter

    # --- what the node reads ---------------------------------------------------------------------
    @property
    def mode(self) -> Mode:
        with self._state.lock:
            return self._state.mode

    @property
    def timing(self) -> EstopTiming:
        return self._timing

    @property
    def history(self) -> tuple[TransitionRecord, ...]:
        """The most recent attempts, oldest first."""
        with self._state.lock:
            return tuple(self._state.history)

    def status(self) -> MachineStatus:
        return self._state.status()

    def allows_cmd_vel(self) -> bool:
        return self._state.allows(modes.allows_cmd_vel)

    def allows_arm_commands(self) -> bool:
        return self._state.allows(modes.allows_arm_commands)

    def allows_loco_commands(self) -> bool:
        return self._state.allows(modes.allows_loco_commands)

    def allows_low_level_commands(self) -> bool:
        return self._state.allows(modes.allows_low_level_commands)

    def is_emergency(self) -> bool:
        return self.mode is Mode.EMERGENCY

    def holding_motion(self) -> bool:
        """A body check holds motion in the current mode (nothing but stopping passes the gate)."""
        with self._state.lock:
            return bool(self._state.holds)

    # --- what the relays and loco commands go through (see gate.py) ------------------------------
    def forwarding(self, predicate: Callable[[Mode], bool]) -> AbstractContextManager[ForwardDecision]:
        """Held around one write; yields the decision: may it pass now, and the mode judged (never around a
        wait for a reply)."""
        return self._gate.forwarding(predicate)

    def robot_call(self, allowed: Callable[[Mode], bool], *, stopping: bool = False) -> AbstractContextManager[bool]:
        """Around a blocking robot-changing call: yields whether it may be sent; registered as in flight.
        ``stopping`` (damp): a body check's hold does not refuse it."""
        return self._gate.robot_call(allowed, stopping=stopping)

    def add_leave_listener(self, listener: LeaveListener) -> None:
        """``listener(source, target)`` runs in the thread that changes the mode, after the gate closed and
        before the transition's first robot call (an e-stop: right after its DampNoReply)."""
        self._state.add_leave_listener(listener)

    # --- mode changes ----------------------------------------------------------------------------
    def request(self, target: Mode) -> Outcome:
        """Change to ``target`` following the transition table; EMERGENCY is the e-stop.

        A plain int (a Mode message constant) is accepted; a number that is no mode raises ValueError.
        Requesting the current mode while the robot does not match it re-runs that mode's entry.
        """
        target = Mode.from_value(int(target))
        if target is Mode.EMERGENCY:
            return self.estop()
        return self._runner.request(target)

    @property
    def low_level_path(self) -> LowLevelPath:
        return LowLevelPath.RELEASE if self.user_ctrl_link is None else LowLevelPath.USER_CTRL

    def hand_back_on_silence(self) -> Outcome:
        """~/lowcmd went silent on the user_ctrl path: LOW_LEVEL -> IDLE with the robot handed back to its
        walk-run controller (upright), or FAULT with PASSIVE (tilted). Refused on the release path."""
        return self._runner.request(Mode.IDLE, Trigger.SILENCE)

    def estop_shot(self) -> list[str]:
        """The e-stop's first packet alone, for an endpoint that fires it from the thread that took the
        request and runs ``estop(fired=...)`` in another; returns the notes to pass on."""
        return self._estop.shot()

    def estop(self, *, wait: bool = True, fired: list[str] | None = None) -> Outcome:
        """Enter EMERGENCY now and damp the robot; always ends in EMERGENCY, whatever fails.

        success=True only once the robot itself was seen damped with the service active. With
        ``wait=False`` (a topic) the sequence runs in a thread of its own and the outcome only says the
        e-stop was registered. ``fired``: the caller already sent the first packet (its notes).
        """
        return self._estop.estop(wait=wait, fired=fired)

    # --- the body checks' reactions (see fault.py) -----------------------------------------------
    def fault(self, faults: tuple[str, ...]) -> bool:
        """A body check's FAULT: a protective stop, never waiting for the robot; True if FAULT was entered."""
        return self._fault.enter(faults)

    def hold(self, holds: tuple[str, ...]) -> None:
        """A body check's HOLD: no new motion in the current mode until clear_fault."""
        self._fault.hold(holds)

    def clear_fault(self, not_clear_because: Callable[[], str], release: Callable[[], None]) -> Outcome:
        """The operator's clear: FAULT -> IDLE, or holds released, once every latched check is clear."""
        return self._fault.clear(not_clear_because, release)

    # --- supervision (see supervisor.py) ---------------------------------------------------------
    def supervise(self, fsm_id: int | None = None, state_age_s: float | None = None) -> None:
        """One periodic look at the robot (the node calls this at ~10 Hz with rt/sportmodestate)."""
        self._supervisor.supervise(fsm_id, state_age_s)

    def report_mismatch(self, reason: str, version: int | None = None) -> None:
        """The robot no longer matches the mode: forwarding stops until a mode is requested again."""
        self._supervisor.report_mismatch(reason, version)
