"""Fixtures of the tests of ROS-free workers (relays, display): collected logs, events without throttling, a fake clock."""

from __future__ import annotations

import pytest

from fakes.fake_clock import FakeClock
from g1_mode_manager.core.events import RelayEvents


@pytest.fixture
def logs() -> list[tuple[str, str]]:
    return []


@pytest.fixture
def events(logs) -> RelayEvents:
    return RelayEvents(lambda level, text: logs.append((level, text)), throttle_s=0.0)


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock(start=100.0)  # the head LED's patterns are read at these exact times
