"""The layers import only downward: a claim the README and docs/architecture.md make, checked here.

``core/`` (the state machine, the robot port, the body checks), ``relay/`` (the stream workers), the rooms
above them (``flight_recorder/``, ``policy_loop/``) and ``display/`` (the head LED) import with ROS and DDS made
unimportable; the relays import neither room, and neither room the node nor the other; the sim shares only ``protocol/``
with the product; g1ctl and the console reach the node over ROS 2, never through its modules, and the
display they share with it imports only the core; benchmarks share the harness with the tests, never
the tests themselves.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "g1_mode_manager"

#: Top-level packages of ROS 2 (client library, its C layers, message packages, launch) and of DDS.
ROS_AND_DDS = ("rclpy", "rcl", "rcl_interfaces", "rcutils", "rmw", "rpyutils", "rosidl", "ament_index_python",
               "launch", "launch_ros", "builtin_interfaces", "std_msgs", "std_srvs", "geometry_msgs", "nav_msgs",
               "sensor_msgs", "diagnostic_msgs", "g1_mode_manager_msgs", "cyclonedds", "unitree_sdk2py")

_IMPORT_ALL_BLOCKED = """
import importlib, pkgutil, sys, traceback

BLOCKED = {blocked!r}


class Blocker:
    def find_spec(self, name, path=None, target=None):
        top = name.partition(".")[0]
        if top in BLOCKED or top.startswith(("rosidl_", "rcl_", "rmw_")):
            raise ImportError(f"{{name}} is blocked: this layer imports no ROS and no DDS")
        return None


sys.meta_path.insert(0, Blocker())
failed = []
for package in {packages!r}:
    root = importlib.import_module(package)
    for module in [package] + [m.name for m in pkgutil.walk_packages(root.__path__, package + ".")]:
        try:
            importlib.import_module(module)
        except ImportError as e:
            ours = [f for f in traceback.extract_tb(e.__traceback__) if "g1_mode_manager" in f.filename]
            where = f" (imported at {{ours[-1].filename}}:{{ours[-1].lineno}})" if ours else ""
            failed.append(f"{{module}}: {{e}}{{where}}")
print("\\n".join(failed))
sys.exit(1 if failed else 0)
"""


def _imports(path: Path) -> Iterator[tuple[int, str, str]]:
    """(line, module, name) of every import in a file, function-level ones included; name '' for ``import m``."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            yield from ((node.lineno, alias.name, "") for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            yield from ((node.lineno, node.module, alias.name) for alias in node.names)


def _offending(folder: Path, bad: callable) -> list[str]:  # type: ignore[valid-type]
    return [f"{path.relative_to(ROOT)}:{line} imports {module}{'.' + name if name else ''}"
            for path in sorted(folder.rglob("*.py")) for line, module, name in _imports(path)
            if bad(module, name)]


def _top(module: str) -> str:
    return module.partition(".")[0]


def _is_ros_or_dds(module: str) -> bool:
    return _top(module) in ROS_AND_DDS or _top(module).startswith(("rosidl_", "rcl_", "rmw_"))


PURE = ("core", "relay", "flight_recorder", "policy_loop", "display", "policy")


def test_core_relay_and_display_import_with_ros_and_dds_blocked() -> None:
    script = _IMPORT_ALL_BLOCKED.format(blocked=ROS_AND_DDS, packages=tuple(f"g1_mode_manager.{p}" for p in PURE))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, f"core/, relay/ and display/ must import without ROS and DDS:\n{done.stdout}{done.stderr}"


def test_core_relay_and_display_name_no_ros_or_dds_module_even_inside_a_function() -> None:
    for layer in PURE:
        found = _offending(PACKAGE / layer, lambda module, _name: _is_ros_or_dds(module))
        assert not found, f"{layer}/ is ROS- and DDS-free:\n" + "\n".join(found)


def test_core_imports_nothing_above_it() -> None:
    above = tuple(f"g1_mode_manager.{p}" for p in ("relay", "flight_recorder", "policy_loop", "sdk", "node", "display",
                                                   "console", "cli", "demo"))
    found = _offending(PACKAGE / "core", lambda module, _name: module.startswith(above))
    assert not found, "core/ imports only core/ and protocol/ of the product:\n" + "\n".join(found)


def _within(module: str, *layers: str) -> bool:
    return any((module + ".").startswith(f"g1_mode_manager.{layer}.") for layer in layers)


def test_the_relays_import_neither_the_flight_recorder_nor_the_policy_loop() -> None:
    found = _offending(PACKAGE / "relay", lambda module, _name: _within(module, "flight_recorder", "policy_loop",
                                                                         "node", "sdk"))
    assert not found, "relay/ sits below the flight recorder and the policy loop:\n" + "\n".join(found)


def test_the_flight_recorder_and_the_policy_loop_import_only_downward_and_not_each_other() -> None:
    for room, other in (("flight_recorder", "policy_loop"), ("policy_loop", "flight_recorder")):
        found = _offending(PACKAGE / room, lambda module, _name, other=other: _within(
            module, other, "node", "sdk", "console", "cli", "display", "demo"))
        assert not found, f"{room}/ imports only core/, protocol/, policy/ and relay/ of the product:\n" + (
            "\n".join(found))


def test_the_display_imports_only_the_core() -> None:
    def bad(module: str, _name: str) -> bool:
        return _top(module) == "g1_mode_manager" and not module.startswith(("g1_mode_manager.display",
                                                                             "g1_mode_manager.core",
                                                                             "g1_mode_manager.protocol"))

    found = _offending(PACKAGE / "display", bad)
    assert not found, "display/ (shared by the node and the console) imports only core/ and protocol/:\n" + (
        "\n".join(found))


def test_the_sim_shares_only_protocol_with_the_product() -> None:
    def bad(module: str, _name: str) -> bool:
        return _top(module) == "g1_mode_manager" and not (module + ".").startswith("g1_mode_manager.protocol.")

    found = _offending(ROOT / "sim", bad)
    assert not found, "sim/ imports only g1_mode_manager.protocol of the product:\n" + "\n".join(found)


def test_cli_and_console_reach_the_node_over_ros_only() -> None:
    for client in ("cli", "console"):
        found = _offending(PACKAGE / client, lambda module, _name: module.startswith(("g1_mode_manager.node",
                                                                                      "g1_mode_manager.relay",
                                                                                      "g1_mode_manager.flight_recorder",
                                                                                      "g1_mode_manager.policy_loop")))
        assert not found, f"{client}/ imports nothing of node/, relay/ or the rooms above it:\n" + "\n".join(found)


def test_benchmarks_import_nothing_of_the_tests_nor_private_names() -> None:
    test_packages = {p.name for p in (ROOT / "test").iterdir() if (p / "__init__.py").exists()} | {"test", "conftest"}

    def bad(module: str, name: str) -> bool:
        private = name.startswith("_") or any(p.startswith("_") and not p.endswith("__") for p in module.split("."))
        return _top(module) in test_packages or private

    found = _offending(ROOT / "bench", bad)
    assert not found, "bench/ shares the harness with the tests, never test/ itself or a module's privates:\n" + (
        "\n".join(found))
