"""The chaos judge's FAULT rule on a made-up record (no sim): the robot must be seen damped within FAULT_DAMPED_S of
the FAULT claim, which a robot already damped when the claim arrives is."""

from __future__ import annotations

import json
from types import SimpleNamespace

from chaos.scenario import FAULT_DAMPED_S, Claims, judge
from g1_mode_manager.protocol import api_ids

HIGH_LEVEL, EMERGENCY, FAULT = 2, 4, 5
END = {"sport": {"fsm_id": 1, "mode": "ai"}}


def _state(t: float, fsm: int) -> dict:
    return {"k": "state", "t": t, "fsm": fsm, "svc": "ai", "fsm_mode": 0}


def _damp(t: float, noreply: bool) -> dict:
    return {"k": "req", "t": t, "svc": "sport", "api": api_ids.LOCO_SET_FSM_ID, "p": json.dumps({"data": 1}),
            "noreply": noreply}  # fmt: skip


def _mode(mode: int, damp_confirmed: bool = False) -> SimpleNamespace:
    return SimpleNamespace(mode=mode, name=str(mode), damp_confirmed=damp_confirmed, holds=[],
                           transition_in_progress=False)  # fmt: skip


def _claims(t_fault: float, t_estop: float) -> Claims:
    claims = Claims(t_estop=t_estop)
    claims.modes = [(1.0, _mode(HIGH_LEVEL)), (t_fault, _mode(FAULT)), (t_fault + 0.5, _mode(FAULT, True)),
                    (t_estop + 0.01, _mode(EMERGENCY, True))]  # fmt: skip
    return claims


def _record(damped_at: float | None, t_estop: float) -> list[dict]:
    events = [_state(0.0, 4)]
    if damped_at is not None:
        events += [_damp(damped_at - 0.001, True), _state(damped_at, 1)]
    events += [_damp(t_estop + 0.001, True), _damp(t_estop + 0.002, False)]
    if damped_at is None:
        events.append(_state(t_estop + 0.003, 1))
    return [*events, {"k": "body", "t": t_estop + 1.0}]


def test_a_robot_damped_just_before_the_claim_arrives_was_seen_damped() -> None:
    # the protective stop's Damp reached the robot 2 ms before the test received ~/mode saying FAULT
    t_fault, t_estop = 10.0, 10.0 + FAULT_DAMPED_S + 5.0
    assert judge(_record(t_fault - 0.002, t_estop), _claims(t_fault, t_estop), END) == []


def test_a_robot_never_damped_in_fault_is_a_violation() -> None:
    t_fault, t_estop = 10.0, 10.0 + FAULT_DAMPED_S + 5.0
    assert f"robot not damped within {FAULT_DAMPED_S} s of FAULT" in judge(_record(None, t_estop), _claims(t_fault, t_estop), END)
