"""Age of a stamped command: fresh, stale, from a clock ahead, and unset stamps."""

from __future__ import annotations

import math

from g1_mode_manager.relay.stamps import stamp_age_s


def test_stamp_age() -> None:
    now_ns = 1_700_000_010_250_000_000
    assert math.isclose(stamp_age_s(now_ns, 1_700_000_010, 0), 0.25)
    assert math.isclose(stamp_age_s(now_ns, 1_700_000_009, 500_000_000), 0.75)
    assert stamp_age_s(now_ns, 1_700_000_011, 0) < 0  # the sender's clock is ahead: not stale
    assert stamp_age_s(now_ns, 0, 0) == math.inf  # never stamped: cannot prove it is fresh
