"""A robot on the floor or folded in a squat up again, as one sequence of verified steps started by the operator
(g1ctl recover and the console's Recover button run this one sequence).

high_level -> damp -> get_up -> balance_stand. The vendor's flows (Unitree's remote-control guide, as quoted and
verified on a G1 in 4paradigm/phanthymotus-driver PR #215): a robot lying on the floor is damped, then gets up with
lie-to-stand (702); one folded in a squat is damped, then gets up with squat-to-stand (706). Damped, lying flat and
folded show the same fsm, so the get-up is chosen by the posture the node reads from the joints and the pelvis
(core/posture.py, published in ~/mode), once the damped robot has settled.

Each step goes through the node's own services, which answer success only once the robot shows the step's outcome;
the first step that fails ends the sequence with what the robot showed. An e-stop preempts whichever step is waiting
(the node answers it "preempted by e-stop"), and nothing after it is sent. A node just started (UNINITIALIZED: the
robot powered on folded or lying) or in IDLE is asked for HIGH_LEVEL first. Refused before anything is sent: a node
in FAULT (clear_fault first), EMERGENCY or LOW_LEVEL; a robot standing already, or hanging (a gantry's robot is
stood up with stand_up, not from the floor).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Final, Protocol

HIGH_LEVEL: Final = "high_level"
DAMP: Final = "damp"
GET_UP: Final = "get_up"
BALANCE_STAND: Final = "balance_stand"
STEPS: Final = (HIGH_LEVEL, DAMP, GET_UP, BALANCE_STAND)
#: The get-up of each posture a damped robot settles in.
GET_UPS: Final = {"lying_back": "lie_to_stand", "lying_front": "lie_to_stand", "squatting": "squat_to_stand",
                  "sitting": "squat_to_stand"}
#: How long a damped robot may take to settle (come to lie on the floor, or sink into its squat), s.
SETTLE_WAIT_S = 5.0
#: Settled: the same posture read this long without a break (a robot falling passes through a squat's knees), s.
SETTLED_FOR_S = 0.5
POLL_S = 0.1


class Answer(Protocol):
    success: bool
    message: str


class RecoveryRobot(Protocol):
    """The node as the sequence sees it: its latest ~/mode (mode name and posture, None before the first) and two
    of its services."""

    def mode(self) -> tuple[str, str] | None: ...
    def set_mode(self, mode: str) -> Answer: ...
    def loco(self, verb: str) -> Answer: ...


@dataclass(frozen=True)
class StepResult:
    step: str
    success: bool
    message: str
    took_s: float


def refusal(mode: str, posture: str) -> str | None:
    """Why the sequence must not start from ``mode`` with the robot in ``posture``, or None."""
    if mode == "FAULT":
        return "the node is in FAULT: clear_fault first (it leaves IDLE), then recover"
    if mode == "EMERGENCY":
        return "the node is in EMERGENCY, which is never left: restart it, then recover"
    if mode not in ("UNINITIALIZED", "IDLE", "HIGH_LEVEL"):
        return f"the node is in {mode}: recovery starts from UNINITIALIZED, IDLE or HIGH_LEVEL"
    if posture == "standing":
        return "the robot stands already: nothing to recover (nothing sent)"
    if posture == "hanging":
        return ("the robot hangs (straight legs, limp, off the floor: a gantry?): recovery gets a robot up from the "
                "floor or a squat; on the gantry use stand_up")
    return None


def recover(robot: RecoveryRobot, *, clock: Callable[[], float] = time.monotonic,
            sleep: Callable[[float], None] = time.sleep, settle_wait_s: float = SETTLE_WAIT_S,
            on_step: Callable[[StepResult], None] | None = None) -> list[StepResult]:
    """Run the steps in order; the list ends with the first failed step (or holds all of them, succeeded).
    ``on_step`` is told each step's result as soon as it is known."""
    results: list[StepResult] = []

    def done(step: str, started: float, success: bool, message: str) -> bool:
        results.append(StepResult(step, success, message, clock() - started))
        if on_step is not None:
            on_step(results[-1])
        return success

    started = clock()
    seen = robot.mode()
    if seen is None:
        done(HIGH_LEVEL, started, False, "no ~/mode from the node yet: is it running?")
        return results
    mode, posture = seen
    if (why := refusal(mode, posture)) is not None:
        done(HIGH_LEVEL, started, False, why)
        return results
    if mode == "HIGH_LEVEL":
        done(HIGH_LEVEL, started, True, "in HIGH_LEVEL already")
    elif not done(HIGH_LEVEL, started, *_answered(robot.set_mode("HIGH_LEVEL"))):
        return results
    started = clock()
    if not done(DAMP, started, *_answered(robot.loco(DAMP))):
        return results
    started = clock()
    posture = _settled(robot, clock, sleep, started + settle_wait_s)
    verb = GET_UPS.get(posture)
    if verb is None:
        done(GET_UP, started, False, f"damped, the robot neither lies nor is folded in a squat after "
                                     f"{settle_wait_s:.0f} s (posture {posture}): no get-up fits, nothing sent")
        return results
    success, message = _answered(robot.loco(verb))
    if not done(GET_UP, started, success, f"{verb} ({posture}): {message}"):
        return results
    done(BALANCE_STAND, clock(), *_answered(robot.loco(BALANCE_STAND)))
    return results


def _answered(answer: Answer) -> tuple[bool, str]:
    return bool(answer.success), str(answer.message)


def _settled(robot: RecoveryRobot, clock: Callable[[], float], sleep: Callable[[float], None], deadline: float) -> str:
    """The posture a damped robot settles in: the first one a get-up fits, read without a break for SETTLED_FOR_S;
    else the last one seen at the deadline."""
    since, last = clock(), ""
    while True:
        seen = robot.mode()
        posture = seen[1] if seen is not None else "unknown"
        now = clock()
        if posture != last:
            since, last = now, posture
        if (posture in GET_UPS and now - since >= SETTLED_FOR_S) or now >= deadline:
            return posture
        sleep(POLL_S)
