"""The console is a client of the mode manager, never a part of it: nothing of the product imports it, and it
imports nothing of the node, its relays, the robot port or g1ctl (only pure definitions: modes, loco verbs,
the LED looks, the body's tilt, the ~/mode QoS, the policy phases, the names of the policies that ship)."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "g1_mode_manager"
CONSOLE = PACKAGE / "console"
ALLOWED = ("g1_mode_manager.console", "g1_mode_manager.core", "g1_mode_manager.display", "g1_mode_manager.topic_qos",
           "g1_mode_manager.protocol", "g1_mode_manager.help_flag", "g1_mode_manager.policy.builtin")


def _imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
    return found


def test_nothing_of_the_product_imports_the_console() -> None:
    for path in PACKAGE.rglob("*.py"):
        if CONSOLE in path.parents:
            continue
        users = {m for m in _imports(path) if m.startswith("g1_mode_manager.console")}
        assert not users, f"{path.relative_to(PACKAGE)} imports {users}"


def test_the_console_imports_only_pure_definitions_of_the_product() -> None:
    for path in CONSOLE.rglob("*.py"):
        ours = {m for m in _imports(path) if m.startswith("g1_mode_manager.")}  # not g1_mode_manager_msgs
        assert all(m.startswith(ALLOWED) for m in ours), f"{path.name} imports {ours}"
