"""Declaring the node's parameters on a real rclpy node: a bad value fails at start, naming the parameter."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest
import rclpy
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from g1_mode_manager.node.settings import Settings, declare_settings


@contextmanager
def node_with(**overrides: object) -> Iterator[Node]:
    """A bare rclpy node given these parameter overrides (as a params file or --ros-args -p would)."""
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("settings_under_test", context=context,
                             parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def test_defaults_without_overrides() -> None:
    with node_with() as node:
        assert declare_settings(node) == Settings()


@pytest.mark.parametrize(("name", "value", "error"), [
    ("head_led_idle", "red", ValueError),
    ("max_vx", -1.0, InvalidParameterValueException),
    ("max_vx", float("nan"), InvalidParameterValueException),
    ("move_duration_s", 5.0, InvalidParameterValueException),
    ("dds_domain", 300, InvalidParameterValueException),
    ("cmd_vel_rate_hz", 10, InvalidParameterTypeException),
])
def test_a_bad_value_fails_at_start_naming_the_parameter(name: str, value: object, error: type) -> None:
    with node_with(**{name: value}) as node, pytest.raises(error, match=name):
        declare_settings(node)
