"""Our message types must carry the robot's minimal type identifiers, or a real G1 never matches them."""

from __future__ import annotations

import pytest

from g1_mode_manager.protocol.dds import apply_robot_type_compat, minimal_type_id
from g1_mode_manager.protocol.idl import BmsState_, LowCmd_, LowState_, Request_, Response_, SportModeState_

# The robot's C++ SDK's minimal type identifiers: the 0xf1 kind byte, then the 14-byte equivalence hash.
ROBOT_TYPE_IDS = {
    LowCmd_: "f16569fc15f0d47aa8600b9e91fbbc",
    LowState_: "f12f38296b52aa0230b92d378b1e39",
    SportModeState_: "f128cfd7f01c80e828b3936ef9adcd",
    Request_: "f1cba4dc965d393ada76b4de081925",
    Response_: "f148c997d379c3e18c530b5f8fe946",
    BmsState_: "f14b98d809a63f63c7cb31a818506b",  # unitree_sdk2 include/unitree/idl/hg/BmsState_.hpp type map
}


@pytest.mark.parametrize("msg_type", list(ROBOT_TYPE_IDS), ids=lambda t: t.__name__)
def test_minimal_type_id_equals_the_robots(msg_type: type) -> None:
    apply_robot_type_compat()
    assert "f1" + minimal_type_id(msg_type) == ROBOT_TYPE_IDS[msg_type]  # 0xf1: EK_MINIMAL
