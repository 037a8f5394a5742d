"""The sim bridge for a test: a fixture that starts one (``harness.sim_bridge``) and stops it after the test.

Other test folders use the fixture factory by importing it into their conftest or module::

    from support.sim_bridge import sim_bridge_factory  # noqa: F401  (pytest fixture)

    def test_x(sdk_channels, sim_bridge_factory):
        bridge = sim_bridge_factory(speed=2.0, faults={"drop": [7101]})

Mind the pitfall in ``harness.sim_bridge``: SDK entities live for the whole session.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any

import pytest

from harness.processes import ManagedProcess
from harness.sim_bridge import SimStatus, shared_sim_status, start_sim_bridge

__all__ = ["SimStatus", "shared_sim_status", "sim_bridge_factory", "start_sim_bridge"]


@pytest.fixture
def sim_bridge_factory(sdk_domain: int) -> Iterator[Callable[..., ManagedProcess]]:
    """``factory(speed=1.0, faults=None, extra_args=())`` starts a bridge; all are stopped after the test.

    One at a time: a second bridge on the same domain would answer the same RPC requests.
    """
    started: list[ManagedProcess] = []

    def factory(*, speed: float = 1.0, faults: dict[str, Any] | None = None,
                extra_args: Sequence[str] = ()) -> ManagedProcess:
        for proc in started:
            if proc.alive():
                proc.stop()
        proc = start_sim_bridge(sdk_domain, speed=speed, faults=faults, extra_args=extra_args)
        started.append(proc)
        return proc

    yield factory
    for proc in started:
        code = proc.stop()
        if code not in (0, None):
            print(f"sim_bridge exited with {code}:\n{proc.output()}")
