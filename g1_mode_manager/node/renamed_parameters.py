"""Parameters renamed in the last release, still read by their old names (when those go, this module goes)."""

from __future__ import annotations

from rclpy.exceptions import ParameterUninitializedException
from rclpy.node import Node
from rclpy.parameter import Parameter

from g1_mode_manager.node.parameter_descriptions import descriptor

#: Renamed parameters, old name -> new name. For one release the old name is still read, so that a params
#: file written for the previous one keeps its meaning: set, it wins over the new name, with a warning.
RENAMED: dict[str, str] = {"cmd_vel_timeout": "cmd_vel_timeout_s", "max_aw": "max_awz"}


def read_old_names(node: Node, defaults: dict[str, object]) -> dict[str, object]:
    """Declare each old name (typed like ``defaults[new]``, without a value); new name -> value for each one
    the user set, warning with both names."""
    taken: dict[str, object] = {}
    for old, new in RENAMED.items():
        default = defaults[new]
        desc = descriptor(new, default)
        desc.description = f"Old name of {new} (read for one more release; set, it wins over {new})."
        node.declare_parameter(old, Parameter.Type.from_parameter_value(default), desc)
        try:
            value = node.get_parameter(old).value
        except ParameterUninitializedException:  # not set: nothing to take
            continue
        node.get_logger().warn(f"parameter {old!r} is deprecated and will be removed: rename it {new!r} "
                               f"(taking {old}={value!r} as {new})")
        taken[new] = value
    return taken
