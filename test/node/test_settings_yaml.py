"""config/mode_manager.yaml names every parameter of the node with the default the node declares.

The YAML is what users copy and edit: a parameter missing from it is one they cannot find, and a value
that differs from the node's default silently changes behaviour between `ros2 run` and `ros2 launch`.
"""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import yaml

from g1_mode_manager.node.settings import Settings

YAML = Path(__file__).resolve().parents[2] / "config" / "mode_manager.yaml"


def _yaml_parameters() -> dict[str, object]:
    (node,) = yaml.safe_load(YAML.read_text()).values()
    return node["ros__parameters"]


def test_yaml_names_every_parameter_with_its_default_and_nothing_else() -> None:
    given = _yaml_parameters()
    defaults = {f.name: f.default for f in fields(Settings)}
    missing = sorted(set(defaults) - set(given))
    unknown = sorted(set(given) - set(defaults))
    # a type differs too: ROS refuses 1 (an integer) for a double parameter
    differing = sorted(f"{name}: yaml {given[name]!r}, node {default!r}" for name, default in defaults.items()
                       if name in given and (given[name] != default or type(given[name]) is not type(default)))
    problems = [f"missing: {missing}" if missing else "", f"not declared by the node: {unknown}" if unknown else "",
                f"not the node's default: {differing}" if differing else ""]
    assert not any(problems), f"{YAML.name}: " + "; ".join(p for p in problems if p)
