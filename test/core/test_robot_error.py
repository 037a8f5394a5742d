"""RobotError answers what a failure means for the robot, so callers need not know the SDK's codes."""

from __future__ import annotations

import pytest

from g1_mode_manager.core.port import RobotError
from g1_mode_manager.protocol import api_ids as api


@pytest.mark.parametrize(("code", "not_sent", "maybe_delivered", "transport"), [
    (api.ERR_CLIENT_SEND, True, False, True),
    (api.ERR_CLIENT_API_TIMEOUT, False, True, True),
    (api.ERR_REFUSED_IN_STATE, False, False, False),
    (api.ERR_SERVER_API_NOT_IMPL, False, False, False),
])
def test_failure_kinds(code: int, not_sent: bool, maybe_delivered: bool, transport: bool) -> None:
    exc = RobotError("SetVelocity", code)
    assert (exc.not_sent, exc.maybe_delivered, exc.transport) == (not_sent, maybe_delivered, transport)
    assert str(exc).startswith(f"SetVelocity failed: {code} (")
