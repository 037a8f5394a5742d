"""The side environment on the robot's Cyclone DDS 0.10.2 (``make setup`` builds ``.venv-cyclone010/``).

It holds the ``cyclonedds==0.10.2`` binding, built against Debian's libddsc 0.10.2, and the Unitree SDK2
Python code over it, and nothing of this project: scripts run there see the robot's DDS stack only.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from support.processes import ManagedProcess

ROOT = Path(__file__).resolve().parents[2]
SIDE_PYTHON = ROOT / ".venv-cyclone010" / "bin" / "python"
STOCK_CLIENT = Path(__file__).resolve().with_name("stock_client.py")


def side_python() -> str:
    """The side environment's interpreter; a missing one fails the test (``make setup`` builds it)."""
    assert SIDE_PYTHON.exists(), f"{SIDE_PYTHON} missing: run `make setup` (it builds the Cyclone 0.10.2 side env)"
    return str(SIDE_PYTHON)


def json_lines(proc: ManagedProcess) -> list[dict[str, Any]]:
    """The JSON objects a script printed, one per line (other lines, e.g. SDK chatter, skipped)."""
    out = []
    for line in proc.output().splitlines():
        if line.startswith("{"):
            try:
                out.append(json.loads(line))
            except ValueError:
                pass
    return out
