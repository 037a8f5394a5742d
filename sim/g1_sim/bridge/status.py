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


def status_handlers(collect: Callable[[], dict[str, Any]]) -> dict[int, Callable[[str], tuple[int, str]]]:
    return {STATUS_GET: lambda parameter: (0, json.dumps(collect()))}
