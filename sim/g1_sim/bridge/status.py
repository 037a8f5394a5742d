"""A status RPC service of the sim only (not on the robot): counters, base pose, real-time factor.

Tests read it with the SDK's plain ``Client`` (service ``g1_sim``, api 9001, reply JSON), so they can
check what the robot cannot report, e.g. how many bad frames were ignored, or where the pelvis is.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any, Final

STATUS_SERVICE: Final = "g1_sim"
STATUS_API_VERSION: Final = "1.0.0.0"
STATUS_GET: Final = 9001
#: Back to the boot state ("ai" selected, no faults; standing unless --boot-posture says otherwise): a harness runs
#: many scenarios on one bridge.
STATUS_RESET: Final = 9002


def status_handlers(collect: Callable[[], dict[str, Any]],
                    reset: Callable[[], None] | None = None) -> dict[int, Callable[[str], tuple[int, str]]]:
    handlers = {STATUS_GET: lambda parameter: (0, json.dumps(collect()))}
    if reset is not None:
        def do_reset(_parameter: str) -> tuple[int, str]:
            reset()
            return (0, json.dumps(collect()))

        handlers[STATUS_RESET] = do_reset
    return handlers
