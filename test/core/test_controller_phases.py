"""The policy lifecycle's table: every verb in every phase either moves to the phase the docs name or is refused
with a reason; nothing reaches the robot's frames outside the sending phases."""

from __future__ import annotations

import pytest

from g1_mode_manager.core.controller.phases import IN_LOW_LEVEL, SENDING, TICKING, Phase, Verb, next_phase

P, V = Phase, Verb


@pytest.mark.parametrize(("verb", "phase", "target"), [
    (V.LOAD, P.UNLOADED, P.LOADED), (V.SHADOW, P.LOADED, P.SHADOW), (V.ENGAGE, P.SHADOW, P.ENGAGING),
    (V.ENTERED, P.ENGAGING, P.BLENDING), (V.BLENDED, P.BLENDING, P.RUNNING), (V.DISENGAGE, P.RUNNING, P.DISENGAGING),
    (V.HOLD, P.RUNNING, P.HOLDING), (V.DISENGAGE, P.HOLDING, P.DISENGAGING), (V.LEFT, P.DISENGAGING, P.LOADED),
    (V.FAULT, P.RUNNING, P.LOADED), (V.FAULT, P.SHADOW, P.LOADED), (V.DISENGAGE, P.SHADOW, P.LOADED),
])
def test_the_lifecycle_moves(verb, phase, target):
    assert next_phase(verb, phase) is target


@pytest.mark.parametrize(("verb", "phase", "why"), [
    (V.ENGAGE, P.LOADED, "shadow the policy first"), (V.ENGAGE, P.UNLOADED, "no policy loaded"),
    (V.LOAD, P.RUNNING, "disengage it first"), (V.SHADOW, P.UNLOADED, "load one first"),
    (V.DISENGAGE, P.LOADED, "nothing to disengage"), (V.ENGAGE, P.RUNNING, "already"),
])
def test_refusals_say_why(verb, phase, why):
    answer = next_phase(verb, phase)
    assert not isinstance(answer, Phase) and why in answer


def test_every_pair_is_answered_and_only_low_level_phases_send():
    for verb in Verb:
        for phase in Phase:
            answer = next_phase(verb, phase)
            assert isinstance(answer, str) and answer
    assert SENDING <= TICKING and SENDING <= IN_LOW_LEVEL
    assert P.SHADOW in TICKING and P.SHADOW not in SENDING
