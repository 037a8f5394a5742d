"""Test isolation: a unique ROS 2 domain and a unique Unitree SDK2 DDS domain per test run, loopback only.

Set before anything imports rclpy or cyclonedds, so every node, client and subprocess of this run
stays on 127.0.0.1 and on domains no other run of this machine uses at the same time.
"""

from __future__ import annotations

import os

from support.domains import allocate_run_domains

_ROS_DOMAIN, _SDK_DOMAIN = allocate_run_domains()
os.environ["ROS_DOMAIN_ID"] = str(_ROS_DOMAIN)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_STATIC_PEERS", None)
os.environ["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
os.environ["G1_TEST_SDK_DOMAIN"] = str(_SDK_DOMAIN)

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


#: Folders whose files run for tens of seconds each (a sim per file or per test), longest kinds first.
_HEAVY_FIRST = ("test/chaos/", "test/e2e/", "test/sim/", "test/packaging/")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The heavy files first: ``--dist loadfile`` hands files to the workers in this order, and starting with
    the longest keeps one of them from running alone at the end. The order within a file is kept."""

    def rank(item: pytest.Item) -> int:
        path = item.path.relative_to(config.rootpath).as_posix()
        return next((i for i, folder in enumerate(_HEAVY_FIRST) if path.startswith(folder)), len(_HEAVY_FIRST))

    items.sort(key=rank)
