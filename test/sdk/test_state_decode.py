"""The struct fast path for rt/sportmodestate agrees with cyclonedds' own deserialisation."""

from __future__ import annotations

import pytest

from g1_mode_manager.protocol.idl import SportModeState_
from g1_mode_manager.sdk.state_readers import decode_sport_state


@pytest.mark.parametrize("values", [(500, 1, 3, 1.5), (1, 0, 0, 0.0), (2**32 - 1, 7, 2**31, -2.25)])
def test_sport_state_fast_decode_matches_cyclonedds(values: tuple[int, int, int, float]) -> None:
    data = SportModeState_(fsm_id=values[0], fsm_mode=values[1], task_id=values[2], task_time=values[3]).serialize()
    assert decode_sport_state(data) == SportModeState_.deserialize(data)
    assert decode_sport_state(bytes(data)).fsm_id == values[0]
