"""The lifecycle of a controller in the node's loop, as one table: which verb or event moves it from which phase
to which, and why every other pair is refused. Pure: the loop (policy_loop/policy_runner.py) asks and acts.

load -> LOADED (checked, nothing sent) -> shadow -> SHADOW (runs on the live state, nothing sent) -> engage ->
ENGAGING (LOW_LEVEL being entered) -> entered -> BLENDING (from the measured pose) -> blended -> RUNNING; disengage
-> DISENGAGING (the robot's own controller takes it back) or hold -> HOLDING (the last pose held in LOW_LEVEL);
left (LOW_LEVEL left by anyone: an e-stop, a FAULT, a hand-back) and fault (inside the loop) -> LOADED.
"""

from __future__ import annotations

from enum import StrEnum


class Phase(StrEnum):
    UNLOADED = "unloaded"
    LOADED = "loaded"
    SHADOW = "shadow"
    ENGAGING = "engaging"
    BLENDING = "blending"
    RUNNING = "running"
    HOLDING = "holding"
    DISENGAGING = "disengaging"


class Verb(StrEnum):
    LOAD = "load"
    UNLOAD = "unload"
    SHADOW = "shadow"
    ENGAGE = "engage"
    ENTERED = "entered"
    BLENDED = "blended"
    DISENGAGE = "disengage"
    HOLD = "hold"
    RESUME = "resume"  # a disengage the machine refused: the policy goes on
    LEFT = "left"
    FAULT = "fault"


P, V = Phase, Verb
IN_LOW_LEVEL = frozenset({P.ENGAGING, P.BLENDING, P.RUNNING, P.HOLDING, P.DISENGAGING})
#: Phases in which the loop ticks: the controller steps (SHADOW, BLENDING, RUNNING) or a hold is written (HOLDING).
#: DISENGAGING keeps the policy balancing the robot until the machine leaves LOW_LEVEL (silence meanwhile would
#: start a hand-back of its own).
TICKING = frozenset({P.SHADOW, P.BLENDING, P.RUNNING, P.HOLDING, P.DISENGAGING})
#: Phases in which the loop's frames go to the robot.
SENDING = frozenset({P.BLENDING, P.RUNNING, P.HOLDING, P.DISENGAGING})

_MOVES: dict[tuple[Verb, Phase], Phase] = {
    (V.LOAD, P.UNLOADED): P.LOADED, (V.LOAD, P.LOADED): P.LOADED,
    (V.UNLOAD, P.LOADED): P.UNLOADED, (V.UNLOAD, P.SHADOW): P.UNLOADED,
    (V.SHADOW, P.LOADED): P.SHADOW,
    (V.ENGAGE, P.SHADOW): P.ENGAGING,
    (V.ENTERED, P.ENGAGING): P.BLENDING,
    (V.BLENDED, P.BLENDING): P.RUNNING,
    (V.DISENGAGE, P.SHADOW): P.LOADED,
    **{(V.DISENGAGE, p): P.DISENGAGING for p in (P.ENGAGING, P.BLENDING, P.RUNNING, P.HOLDING)},
    **{(V.HOLD, p): P.HOLDING for p in (P.BLENDING, P.RUNNING)},
    (V.RESUME, P.DISENGAGING): P.RUNNING,
    **{(V.LEFT, p): P.LOADED for p in IN_LOW_LEVEL},
    **{(V.FAULT, p): P.LOADED for p in (P.SHADOW, P.ENGAGING, *SENDING)},
}


def next_phase(verb: Verb, phase: Phase) -> Phase | str:
    """The phase ``verb`` leads to from ``phase``, or why it is refused there."""
    match _MOVES.get((verb, phase)), verb, phase:
        case Phase() as target, _, _:
            return target
        case None, V.UNLOAD, P.UNLOADED:
            return "no policy loaded"
        case None, V.LOAD | V.UNLOAD, _:
            return f"a policy is {phase.value}: disengage it first"
        case None, V.SHADOW, P.UNLOADED:
            return "no policy loaded: load one first"
        case None, V.SHADOW, _:
            return f"the policy is {phase.value} already" if phase is P.SHADOW else f"the policy is {phase.value}"
        case None, V.ENGAGE, P.LOADED:
            return "shadow the policy first: engaging needs its targets seen against the live robot"
        case None, V.ENGAGE, P.UNLOADED:
            return "no policy loaded: load one, shadow it, then engage"
        case None, V.ENGAGE, _:
            return f"the policy is {phase.value} already"
        case None, V.DISENGAGE | V.HOLD, _:
            return f"the policy is {phase.value}: nothing to disengage"
        case None, _, _:
            return f"{verb.value} does not apply while the policy is {phase.value}"
    raise AssertionError("unreachable")  # pragma: no cover
