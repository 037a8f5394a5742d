"""Test isolation: a unique ROS 2 domain and a unique Unitree SDK2 DDS domain per test run, loopback only.

Set before anything imports rclpy or cyclonedds, so every node, client and subprocess of this run
stays on 127.0.0.1 and on domains no other run of this machine uses at the same time.
"""

from __future__ import annotations

from support.standalone import isolate

_ROS_DOMAIN, _SDK_DOMAIN = isolate()

import pytest  # noqa: E402


@pytest.fixture(scope="session")
def ros_domain() -> int:
    """The ROS_DOMAIN_ID of this test run (already in the environment)."""
    return _ROS_DOMAIN


@pytest.fixture(scope="session")
def sdk_domain() -> int:
    """The Unitree SDK2 (Cyclone DDS) domain of this test run, on loopback."""
    return _SDK_DOMAIN


@pytest.fixture(scope="session")
def sdk_channels(sdk_domain: int) -> int:
    """Initialise the SDK's process-wide DDS domain for in-process clients (loopback, no multicast).

    Only SDK *clients* live in the pytest process; every SDK server (the sim bridge, scripted
    robots) runs in a subprocess on this domain, one at a time.
    """
    from g1_mode_manager.protocol.dds import init_channels

    init_channels(sdk_domain, "lo")
    return sdk_domain


#: The slowest files, slowest first (per-file sums of --durations=0 in a four-worker run; figures in
#: docs/figures.md); then every other file of these folders, then the rest.
_SLOWEST_FIRST = (
    "test/e2e/test_user_ctrl.py",
    "test/e2e/test_end_to_end.py",
    "test/e2e/test_streams.py",
    "test/e2e/test_estop_truth.py",
    "test/sim/test_stock_clients.py",
    "test/e2e/test_drivers.py",
    "test/chaos/test_chaos.py",
    "test/chaos/test_chaos_second_half.py",
    "test/e2e/test_getup.py",
    "test/e2e/test_body.py",
    "test/e2e/test_policy.py",
    "test/e2e/test_console_browser.py",
    "test/e2e/test_user_ctrl_estop_steps.py",
    "test/sim/test_bridge.py",
    "test/sdk/test_unitree_robot.py",
    "test/e2e/test_windows.py",
    "test/e2e/test_loco_outcome.py",
    "test/e2e/test_odometry.py",
    "test/sim/test_body.py",
    "test/sim/test_robot_topics.py",
    "test/e2e/test_head_led.py",
    "test/sim/test_stance.py",
    "test/sim/test_user_ctrl.py",
    "test/e2e/test_two_robots.py",
    "test/sim/test_arm_tasks.py",
    "test/sim/test_viewer.py",
    "test/console/test_console_process.py",
    "test/e2e/test_joint_states.py",
)
_HEAVY_FOLDERS = ("test/e2e/", "test/sim/", "test/chaos/", "test/packaging/")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The slowest files first: ``make test`` runs ``--dist loadfile --no-loadscope-reorder``, so xdist hands
    files to the workers in this order as they come free, and starting with the longest keeps one worker
    from running alone at the end. The order within a file is kept."""

    def rank(item: pytest.Item) -> tuple[int, int]:
        path = item.path.relative_to(config.rootpath).as_posix()
        if path in _SLOWEST_FIRST:
            return (0, _SLOWEST_FIRST.index(path))
        return (1, 0) if path.startswith(_HEAVY_FOLDERS) else (2, 0)

    items.sort(key=rank)
