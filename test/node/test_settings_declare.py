"""Declaring the node's parameters on a real rclpy node: a bad value fails at start, naming the parameter."""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
import rclpy
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.node.mode_manager import ModeManagerNode
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
    ("recorder_window_s", 0.0, InvalidParameterValueException),
    ("recorder_max_files", 0, InvalidParameterValueException),
])
def test_a_bad_value_fails_at_start_naming_the_parameter(name: str, value: object, error: type) -> None:
    with node_with(**{name: value}) as node, pytest.raises(error, match=name):
        declare_settings(node)


@pytest.mark.parametrize(("old", "new"), [("cmd_vel_timeout", "cmd_vel_timeout_s"), ("max_aw", "max_awz")])
def test_an_old_parameter_name_still_applies_for_one_release_with_a_warning(old: str, new: str, capfd) -> None:
    with node_with(**{old: 0.3}) as node:
        settings = declare_settings(node)
        assert getattr(settings, new) == 0.3
        assert node.get_parameter(new).value == 0.3  # what `ros2 param get` shows is what is used
    err = capfd.readouterr().err
    warning = [line for line in err.splitlines() if "WARN" in line and f"'{old}'" in line]
    assert warning and f"'{new}'" in warning[0], err


def test_an_old_name_wins_over_the_new_one_and_unset_old_names_say_nothing(capfd) -> None:
    with node_with(cmd_vel_timeout=0.3, cmd_vel_timeout_s=0.7, max_awz=2.5) as node:
        settings = declare_settings(node)
    assert (settings.cmd_vel_timeout_s, settings.max_awz) == (0.3, 2.5)
    err = capfd.readouterr().err
    assert "'cmd_vel_timeout'" in err and "max_aw'" not in err


def test_an_old_name_out_of_range_fails_naming_it() -> None:
    with node_with(cmd_vel_timeout=-1.0) as node, pytest.raises(InvalidParameterValueException, match="cmd_vel_timeout"):
        declare_settings(node)


def test_the_node_runs_on_an_old_name(capfd) -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    node = ModeManagerNode(port_factory=lambda _s: FakeRobotPort(), context=context,
                           parameter_overrides=[Parameter("cmd_vel_timeout", value=0.3)])
    try:
        assert node.settings.cmd_vel_timeout_s == 0.3
    finally:
        node.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    assert "rename it 'cmd_vel_timeout_s'" in capfd.readouterr().err


@pytest.mark.parametrize(("name", "value"), [("low_level_path", "limp"), ("user_ctrl_silence", "ignore"),
                                             ("user_ctrl_hold_kp", 900.0)])
def test_the_low_level_path_parameters_are_validated_naming_them(name: str, value: object) -> None:
    with node_with(**{name: value}) as node, pytest.raises((ValueError, InvalidParameterValueException), match=name):
        declare_settings(node)


def test_the_low_level_path_chooses_the_user_ctrl_settings() -> None:
    with node_with() as node:
        config = declare_settings(node).user_ctrl_config()
        assert config is not None and config.silence.value == "hand_back"  # the default: user control
    with node_with(low_level_path="release") as node:
        assert declare_settings(node).user_ctrl_config() is None


@pytest.mark.parametrize(("overrides", "error"), [
    ({"policy_engage_keys": "L2+B"}, "policy_engage_keys: 'L2+B' is the same combination as remote_estop_keys 'L2+B'"),
    ({"policy_engage_keys": "B"}, "policy_engage_keys: 'B' is part of remote_estop_keys 'L2+B'"),
    ({"policy_disengage_keys": "L2+B+up"}, "policy_disengage_keys: 'L2+B+up' holds every key of remote_estop_keys"),
    ({"policy_disengage_keys": "R1+X+A"}, "policy_disengage_keys: 'R1+X+A' holds every key of policy_engage_keys"),
    ({"remote_estop_keys": "R1", "policy_disengage_keys": ""},
     "policy_engage_keys: 'R1+X' holds every key of remote_estop_keys 'R1'"),
])
def test_a_remote_combination_that_would_press_another_fails_at_start(overrides: dict, error: str) -> None:
    with node_with(**overrides) as node, pytest.raises(ValueError, match=re.escape(f"parameter {error}")):
        declare_settings(node)


def test_the_policys_remote_keys_default_to_rl_labs_and_take_any_case_or_none() -> None:
    with node_with() as node:
        settings = declare_settings(node)
    assert (settings.policy_engage_keys, settings.policy_disengage_keys) == ("R1+X", "L2+Up")
    with node_with(policy_engage_keys="r1 + x", policy_disengage_keys="", remote_estop_keys="") as node:
        assert declare_settings(node).policy_engage_keys == "r1 + x"


def test_the_recorders_folder_is_its_parameter_or_the_users_state_folder(monkeypatch) -> None:
    monkeypatch.setenv("XDG_STATE_HOME", "/state")
    config = Settings().recorder_config("/g1_mode_manager")
    assert str(config.folder) == "/state/g1_mode_manager/incidents" and config.node == "/g1_mode_manager"
    assert (config.window_s, config.after_s, config.max_files, config.body_rate_hz) == (30.0, 3.0, 50, 100.0)
    assert config.max_bytes == 500_000_000  # MB, as the parameter says
    monkeypatch.setenv("HOME", "/home/op")
    assert str(Settings(recorder_dir="~/incidents").recorder_config("").folder) == "/home/op/incidents"
