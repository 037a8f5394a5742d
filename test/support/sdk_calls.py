"""SDK2 clients for tests: one call through a client's generic ``_Call`` by api id, with its JSON parameter and
answer (for the apis the Python SDK's clients have no method for: GetFsmMode, SwitchToUserCtrl, ...), and the
SDK's objects initialised in one expression."""

from __future__ import annotations

import json
from typing import Any


def call(client: Any, api_id: int, parameter: dict[str, Any] | None = None) -> tuple[int, Any]:
    """(code, the answer's data as JSON or None)."""
    code, data = client._Call(api_id, json.dumps(parameter if parameter is not None else {}))
    return code, (json.loads(data) if code == 0 and data else None)


def initialised(obj: Any) -> Any:
    """``obj`` after its ``Init()`` (an SDK client, publisher or subscriber)."""
    obj.Init()
    return obj
