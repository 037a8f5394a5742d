"""~/loco_command: when a verb of the built-in controller may reach the robot, the sending of it, and its
answer, given only once the robot shows the verb's outcome (relay/loco_outcome.py), or at once, with nothing
sent, when that outcome holds already.

ROS-free: the node serves the request, this decides, sends and judges; the verbs are core/loco_verbs.py.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Protocol

from g1_mode_manager.core import modes
from g1_mode_manager.core.loco_verbs import LOCO_VERBS, FsmShown
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotError, RobotPort
from g1_mode_manager.core.posture import NO_READING, PostureReading
from g1_mode_manager.core.posture_guards import posture_refusal
from g1_mode_manager.protocol.fsm import FsmMode
from g1_mode_manager.relay.loco_outcome import OutcomeWatch, Preemption, Seen

#: LocoCommand code of a command refused here, or answered on an outcome that held already: nothing was sent.
NOT_SENT = -1


@dataclass(frozen=True)
class LocoResult:
    """``outcome_s``: from the send to the outcome seen on the robot; -1 when it was not seen."""

    success: bool
    message: str
    code: int = NOT_SENT
    outcome_s: float = -1.0


class LocoGate(Protocol):
    """What a loco command asks of the mode machine (see ModeMachine.robot_call)."""

    @property
    def mode(self) -> Mode: ...
    def robot_call(self, allowed: Callable[[Mode], bool]) -> AbstractContextManager[bool]: ...


def _damp_allowed(mode: Mode) -> bool:
    return mode not in (Mode.UNINITIALIZED, Mode.LOW_LEVEL)


class LocoCommands:
    """Serves loco commands on one robot port; ``on_leave`` (a mode machine leave listener) preempts the
    commands still waiting for their outcome."""

    def __init__(self, port: RobotPort, gate: LocoGate, *, outcome_timeout_s: float = 3.0,
                 motion_timeout_s: float = 6.0, get_up_timeout_s: float = 12.0,
                 posture: Callable[[], PostureReading] = lambda: NO_READING) -> None:
        self._port = port
        self._gate = gate
        self._watch = OutcomeWatch(port, timeout_s=outcome_timeout_s, motion_timeout_s=motion_timeout_s,
                                   get_up_timeout_s=get_up_timeout_s, posture=posture)
        self._posture = posture
        self._lock = threading.Lock()
        self._waiting: set[Preemption] = set()

    def on_leave(self, source: Mode, target: Mode) -> None:
        """Runs in the thread that changes the mode (the e-stop's among them): only sets events."""
        reason = "preempted by e-stop" if target is Mode.EMERGENCY else f"preempted: mode {source.name} -> {target.name}"
        with self._lock:
            waiting = tuple(self._waiting)
        for preemption in waiting:
            preemption.preempt(reason)

    def run(self, command: str, value: int) -> LocoResult:
        """Check, send, then wait for the robot to show the outcome (see run_loco_command)."""
        preemption = Preemption()
        with self._lock:  # registered before the send: a mode change from here on preempts the wait
            self._waiting.add(preemption)
        try:
            return run_loco_command(self._port, self._gate, command, value, self._watch, preemption, self._posture)
        finally:
            with self._lock:
                self._waiting.discard(preemption)


def run_loco_command(port: RobotPort, gate: LocoGate, command: str, value: int, watch: OutcomeWatch,
                     preemption: Preemption,
                     posture: Callable[[], PostureReading] = lambda: NO_READING) -> LocoResult:
    """Check the command against the mode and the robot's state, send it, then wait for its outcome.

    Damping is allowed wherever the sport service can answer (every connected mode but LOW_LEVEL);
    everything else only in HIGH_LEVEL (with no transition in flight) and only while the robot is
    static (fsm_mode 0), as the robot itself would refuse most switches while dynamic. A posture verb whose
    outcome holds already is answered so, with nothing sent; otherwise it is sent only where the robot's body
    allows it (``posture``: the body watch's reading; core/posture_guards.py). The mode check and the send are
    one ``robot_call``: an e-stop that begins meanwhile refuses it, or waits for it to land and then re-damps.
    The outcome wait comes after, outside the gate, so it never delays an e-stop; ``success`` only once the
    robot showed the outcome (code 0 alone is not enough).
    """
    mode = gate.mode
    name = command.strip().lower()
    verb = LOCO_VERBS.get(name)
    if verb is None:
        return LocoResult(False, f"unknown command {command!r}; valid: {', '.join(LOCO_VERBS)}")
    r = verb.values
    if r is not None and value not in r:
        return LocoResult(False, f"{name} takes a value from {r.start} to {r.stop - 1}, got {value}")
    expected = verb.expect(value)
    if name == "damp":
        if mode is Mode.UNINITIALIZED:
            return LocoResult(False, "not connected to the robot yet (UNINITIALIZED): use ~/estop or set a mode first")
        if mode is Mode.LOW_LEVEL:
            return LocoResult(False, "LOW_LEVEL: the sport service is released, damping is impossible; use ~/estop, "
                                     "which re-selects the service and then damps")
    else:
        if not modes.allows_loco_commands(mode):
            return _not_allowed(mode)
        state = port.sport_state()
        if state is None:
            return LocoResult(False, "no rt/sportmodestate received: the robot's state is unknown")
        if state.fsm_mode == FsmMode.DYNAMIC:
            return LocoResult(False, "the robot is dynamic (fsm_mode 1): only damp is allowed; stop it first")
        reading = posture()
        if isinstance(expected, FsmShown) and expected.already(state.fsm_id, state.fsm_mode, reading.posture):
            # sending it anyway could only undo it: 706 squats a standing robot and stands a squatting one
            return LocoResult(True, f"{name}: already {reading.describe()} (fsm {state.fsm_id}): nothing sent")
        refusal = posture_refusal(name, state.fsm_id, reading)
        if refusal is not None:
            return LocoResult(False, refusal)
    before = watch.before(expected)
    with gate.robot_call(_damp_allowed if name == "damp" else modes.allows_loco_commands) as allowed:
        if not allowed:
            return _not_allowed(gate.mode)
        sent_at = time.monotonic()
        try:
            verb.send(port, value)
        except RobotError as exc:
            return LocoResult(False, str(exc), exc.code)
    what = name + (f" (value {value})" if r is not None else "")
    return _judged(what, watch.wait(expected, sent_at, before, preemption), watch.limit_s(expected))


def _judged(what: str, seen: Seen, limit_s: float) -> LocoResult:
    if seen.preempted is not None:
        return LocoResult(False, f"{what}: code 0, {seen.preempted} after {seen.after_s:.2f} s "
                                 f"(the robot showed {seen.shown})", 0)
    if seen.ok:
        return LocoResult(True, f"{what}: done, the robot shows {seen.shown} after {seen.after_s:.2f} s",
                          0, seen.after_s)
    if seen.after_s == 0.0:  # nothing to read back: the return code is all there is
        return LocoResult(True, f"{what}: code 0, {seen.shown}", 0)
    if seen.still:
        return LocoResult(False, f"{what}: code 0, the robot accepted it and did not move: it showed {seen.shown} "
                                 f"for {limit_s:.1f} s", 0)
    return LocoResult(False, f"{what}: code 0, but the robot showed {seen.shown} for {limit_s:.1f} s", 0)


def _not_allowed(mode: Mode) -> LocoResult:
    return LocoResult(False, f"mode is {mode.name}: loco commands are allowed only in HIGH_LEVEL "
                             "(not during a transition, an e-stop or a robot/mode mismatch)")
