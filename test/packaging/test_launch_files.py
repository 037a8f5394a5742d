"""The launch files without a launch install (no launch/launch_ros wheel exists): valid Python, the arguments
the README promises, network_interface required on the robot. docs/launch_check.md records the run of
both files under the real launch/launch_ros (jazzy) at development time."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

LAUNCH = Path(__file__).resolve().parents[2] / "launch"


def _arguments(path: Path) -> dict[str, bool]:
    """DeclareLaunchArgument name -> has a default."""
    out = {}
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "DeclareLaunchArgument":
            name = node.args[0]
            assert isinstance(name, ast.Constant)
            out[name.value] = any(k.arg == "default_value" for k in node.keywords)
    return out


@pytest.mark.parametrize(("name", "required", "optional"), [
    ("sim.launch.py", set(), {"domain", "namespace", "speed", "viewer", "params_file", "odom_rate_hz", "console",
                              "console_host", "console_port", "console_token_file"}),
    ("robot.launch.py", {"network_interface"}, {"params_file", "namespace", "dds_domain", "joint_state_rate_hz",
                                                "odom_rate_hz", "console", "console_host", "console_port",
                                                "console_token_file"}),
])
def test_launch_arguments(name: str, required: set[str], optional: set[str]) -> None:
    args = _arguments(LAUNCH / name)
    assert {k for k, has_default in args.items() if not has_default} == required
    assert optional <= {k for k, has_default in args.items() if has_default}
    assert "generate_launch_description" in (LAUNCH / name).read_text()


def test_launch_files_build_their_description_where_launch_is_installed() -> None:
    pytest.importorskip("launch_ros")
    from launch.launch_description_sources import get_launch_description_from_python_launch_file

    for path in sorted(LAUNCH.glob("*.launch.py")):
        assert get_launch_description_from_python_launch_file(str(path)).entities


@pytest.mark.parametrize("executable", ["mode_manager", "console"])
@pytest.mark.parametrize("name", ["sim.launch.py", "robot.launch.py"])
def test_launch_files_run_the_node_on_fast_dds_whatever_the_shell_exports(name: str, executable: str) -> None:
    """A G1 user's shell often exports rmw_cyclonedds_cpp (Unitree's instructions), which the node refuses; the
    console runs on the product's RMW too."""
    tree = ast.parse((LAUNCH / name).read_text())
    nodes = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, "id", "") == "Node"
             and any(k.arg == "executable" and getattr(k.value, "value", "") == executable for k in n.keywords)]
    assert nodes
    for node in nodes:
        env = next(ast.literal_eval(k.value) for k in node.keywords if k.arg == "additional_env")
        assert env == {"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}


@pytest.mark.parametrize(("name", "default"), [("sim.launch.py", "true"), ("robot.launch.py", "false")])
def test_the_console_is_on_for_the_sim_and_asked_for_on_a_real_robot(name: str, default: str) -> None:
    tree = ast.parse((LAUNCH / name).read_text())
    declared = {n.args[0].value: n for n in ast.walk(tree) if isinstance(n, ast.Call)
                and getattr(n.func, "id", "") == "DeclareLaunchArgument"}
    assert next(k.value.value for k in declared["console"].keywords if k.arg == "default_value") == default
    assert next(k.value.value for k in declared["console_host"].keywords if k.arg == "default_value") == "127.0.0.1"
