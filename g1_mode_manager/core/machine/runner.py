"""The transition runner: executes one rule of the transition table against the robot.

One request runs at a time, in the caller's thread; a second one arriving meanwhile is refused at once
("busy: ..."), never queued. The transition starts under the forward gate (so no relay write is under
way and none passes while it runs), then the leave listeners run (streams close, damping frames go out),
then the rule's steps. An e-stop can preempt it at any moment: the run then makes no further robot call
and commits nothing. A failed step keeps the old mode and says why.
"""

from __future__ import annotations

from collections.abc import Callable

from g1_mode_manager.core.machine.gate import ForwardGate
from g1_mode_manager.core.machine.state import Inflight, MachineState
from g1_mode_manager.core.machine.user_ctrl_steps import UserCtrlSteps
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import ModePort, RobotError
from g1_mode_manager.core.preemption import Preempted, RunPort
from g1_mode_manager.core.records import Outcome, Result, TransitionRecord
from g1_mode_manager.core.service_steps import StepTimeoutError, ensure_service_active, release_service
from g1_mode_manager.core.transitions import ZERO_TORQUE_NOTE, Step, Transition, Trigger, lookup, rule_for
from g1_mode_manager.core.user_ctrl import NotUpright, UserCtrlRefused
from g1_mode_manager.protocol.fsm import InternalCtrl


class TransitionRunner:
    """Runs ``request(target)`` for every target but EMERGENCY (that is the e-stop's)."""

    def __init__(self, state: MachineState, gate: ForwardGate, port: ModePort, *, release_timeout_s: float,
                 select_timeout_s: float, poll_interval_s: float, belief_period_s: float,
                 sleep: Callable[[float], None]) -> None:
        self._state = state
        self._gate = gate
        self._port = port
        self._release_timeout_s = release_timeout_s
        self._select_timeout_s = select_timeout_s
        self._poll_interval_s = poll_interval_s
        self._belief_period_s = belief_period_s
        self._sleep = sleep
        self._running = False  # guarded by state.lock: a request is being handled
        #: The user_ctrl path's steps (None: low_level_path release) and what a tilted hand-back enters (FAULT).
        self.user_ctrl: UserCtrlSteps | None = None
        self.fault: Callable[[tuple[str, ...]], bool] = lambda _faults: False

    def request(self, target: Mode, trigger: Trigger = Trigger.REQUEST) -> Outcome:
        state = self._state
        start = state.clock()
        with state.lock:
            busy, self._running = self._running, True
            source, inflight = state.mode, state.inflight
        if busy:
            if source is Mode.EMERGENCY:
                reason = str(lookup(source, target))
            elif inflight is not None:
                reason = f"busy: transition {inflight.source.name}->{inflight.target.name} in progress"
            else:
                reason = "busy: another mode request is being handled"
            return self.refuse(source, target, reason, start)
        try:
            with self._gate.lock, state.lock:
                source = state.mode
                rule = rule_for(source, target, mismatch=bool(state.mismatch), trigger=trigger,
                                user_ctrl=self.user_ctrl is not None)
                inflight = None
                if isinstance(rule, Transition) and target is Mode.LOW_LEVEL and state.holds:
                    # in LOW_LEVEL a hold damps the robot: entering it would only hand a standing robot to damping.
                    # Judged under the gate's lock, as hold() is: a hold claimed later finds the entry in flight
                    rule = (f"LOW_LEVEL refused while a body check holds motion ({', '.join(state.holds)}); "
                            "~/clear_fault releases the hold once its checks are clear")
                if isinstance(rule, Transition):
                    inflight = Inflight(source, target)
                    state.inflight = inflight
                    state.version += 1
                elif state.faults and source is Mode.FAULT:
                    rule = f"{rule}; active faults: {', '.join(state.faults)}"
            if not isinstance(rule, Transition) or inflight is None:
                return self.refuse(source, target, str(rule), start)
            state.notify()
            if source is not target:
                state.leaving(source, target)
            return self._execute(rule, inflight, start)
        finally:
            with state.lock:
                self._running = False

    def refuse(self, source: Mode, target: Mode, reason: str, start: float) -> Outcome:
        state = self._state
        duration = state.clock() - start
        record = TransitionRecord(source, target, Result.REFUSED, duration, reason)
        with state.lock:
            state.last_refusal = reason
            state.history.append(record)
            state.version += 1
            mode = state.mode
        state.emit(record)
        return Outcome(False, mode, reason, duration, refused=True)

    def _execute(self, rule: Transition, inflight: Inflight, start: float) -> Outcome:
        state = self._state
        calls = RunPort(self._port, state.note_service, self._sleep, inflight.preempted,
                        changing_call=self._gate.transition_call)
        error = refused = tilted = shown = ""
        selected = False
        try:
            selected, shown = self._run_steps(rule, calls)
        except Preempted:
            pass
        except UserCtrlRefused as exc:
            refused = str(exc)
        except NotUpright as exc:
            tilted = error = f"{exc}: SwitchToInternalCtrl(PASSIVE) and FAULT"
        except (RobotError, StepTimeoutError) as exc:
            error = str(exc)
        except Exception as exc:  # a port must raise RobotError; anything else is reported, not raised
            error = f"unexpected {type(exc).__name__} from the robot port: {exc}"
        duration = state.clock() - start
        source, target = inflight.source.name, inflight.target.name
        with state.lock:
            if state.inflight is inflight:
                state.inflight = None
            if inflight.preempted.is_set():  # the e-stop owns the mode now; commit nothing
                result, message = Result.PREEMPTED, f"{source}->{target} preempted by e-stop"
            elif refused:  # nothing changed on the robot (or it was handed back): the answer is the reason itself
                result, message = Result.REFUSED, refused
                state.last_refusal = message
            elif error:
                result, message = Result.FAILED, f"{source}->{target} failed, staying in {source}: {error}"
                state.last_refusal = message
                state.last_error = error
            else:
                state.mode = inflight.target
                state.mismatch = ""
                state.next_belief = state.clock() + self._belief_period_s
                result, message = Result.OK, f"{source}->{target}: {rule.description}"
                if shown:
                    message += f" ({shown})"
                if rule.trigger is Trigger.SILENCE:  # not asked for by anyone: ~/mode must say why the mode changed
                    state.last_error = message
                if selected or rule.leaves_robot_limp:
                    message += f"; {ZERO_TORQUE_NOTE}"
            if self.user_ctrl is not None and Mode.LOW_LEVEL in (inflight.source, inflight.target) \
                    and result in (Result.OK, Result.FAILED):
                message += " [low_level_path: user_ctrl]"
            state.version += 1
            mode = state.mode
            record = TransitionRecord(inflight.source, inflight.target, result, duration, message)
            state.history.append(record)
        state.emit(record)
        if tilted:  # the walk-run controller cannot take a tilted robot: PASSIVE (FAULT's sequence) and FAULT
            self.fault((f"user_ctrl hand-back: {tilted}",))
        return Outcome(result is Result.OK, mode, message, duration, refused=bool(refused))

    def _run_steps(self, rule: Transition, calls: RunPort) -> tuple[bool, str]:
        """Run the rule's steps; True if SelectMode was sent (the robot is then limp), and what the robot showed."""
        selected = False
        shown = ""
        for step in rule.steps:
            match step:
                case Step.CONNECT:
                    calls.connect()
                    self._state.set_connected()
                case Step.ENSURE_SERVICE_ACTIVE:
                    selected = ensure_service_active(calls, timeout_s=self._select_timeout_s,
                                                     poll_interval_s=self._poll_interval_s, clock=self._state.clock,
                                                     sleep=calls.sleep)
                case Step.RELEASE_SERVICE:
                    release_service(calls, timeout_s=self._release_timeout_s, poll_interval_s=self._poll_interval_s,
                                    clock=self._state.clock, sleep=calls.sleep)
                case Step.USER_CTRL:
                    shown = self._user_ctrl().enter(calls)
                case Step.HAND_BACK_LAST:
                    shown = self._user_ctrl().hand_back(calls, InternalCtrl.LAST)
                case Step.HAND_BACK_WALKRUN:
                    shown = self._user_ctrl().hand_back(calls, InternalCtrl.WALKRUN)
                case Step.ESTOP | Step.PROTECTIVE_STOP:
                    raise AssertionError("the e-stop runs EMERGENCY and FAULT, not the transition runner")
        return selected, shown

    def _user_ctrl(self) -> UserCtrlSteps:
        if self.user_ctrl is None:
            raise AssertionError("a user_ctrl step in a rule of the release path")
        return self.user_ctrl
