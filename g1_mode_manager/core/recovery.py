"""A fallen robot up again as one sequence of verified steps, started by the operator (g1ctl recover and the
console's Recover button run this one sequence).

damp -> lie_to_stand -> balance_stand, each through ~/loco_command, which answers success only once the robot
shows the step's outcome; the first step that fails ends the sequence with what the robot showed. An e-stop
preempts whichever step is waiting (the node answers it "preempted by e-stop"), and nothing after it is sent.
A damped robot takes a moment to come to rest on the floor, so lie_to_stand is asked again while the node
refuses it only because the robot is not lying yet.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from g1_mode_manager.core.posture_guards import NOT_LYING

STEPS = ("damp", "lie_to_stand", "balance_stand")
#: How long a damped robot may take to lie on the floor before lie_to_stand is given up, s.
LYING_WAIT_S = 5.0
RETRY_S = 0.25


class LocoAnswer(Protocol):
    success: bool
    code: int
    message: str
    outcome_s: float


@dataclass(frozen=True)
class StepResult:
    step: str
    success: bool
    message: str
    took_s: float


def recover(loco: Callable[[str], LocoAnswer], *, clock: Callable[[], float] = time.monotonic,
            sleep: Callable[[float], None] = time.sleep, lying_wait_s: float = LYING_WAIT_S,
            on_step: Callable[[StepResult], None] | None = None) -> list[StepResult]:
    """Run the steps in order; the list ends with the first failed step (or holds all of them, succeeded).
    ``on_step`` is told each step's result as soon as it is known."""
    results: list[StepResult] = []
    for step in STEPS:
        started = clock()
        answer = loco(step)
        while (step == "lie_to_stand" and not answer.success and NOT_LYING in answer.message
               and clock() - started < lying_wait_s):
            sleep(RETRY_S)
            answer = loco(step)
        results.append(StepResult(step, answer.success, answer.message, clock() - started))
        if on_step is not None:
            on_step(results[-1])
        if not answer.success:
            break
    return results
