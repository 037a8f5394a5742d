"""g1ctl drives the cmd_vel of the manager it talks to: one robot per namespace."""

from g1_mode_manager.cli.client import cmd_vel_topic


def test_cmd_vel_follows_the_managers_namespace() -> None:
    assert cmd_vel_topic("/g1_mode_manager") == "/cmd_vel"
    assert cmd_vel_topic("/g1_a/g1_mode_manager") == "/g1_a/cmd_vel"
    assert cmd_vel_topic("/fleet/g1_b/g1_mode_manager/") == "/fleet/g1_b/cmd_vel"
