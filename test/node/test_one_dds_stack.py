"""The node refuses rmw_cyclonedds (a second libddsc beside the SDK's) with a message that says what to do."""

from __future__ import annotations

import os
import subprocess

import pytest

from g1_mode_manager.node.one_dds_stack import refusal_from_environment, second_dds_stack
from support.processes import python_module


@pytest.mark.parametrize("rmw", ["rmw_cyclonedds_cpp", "rmw_cyclonedds"])
def test_cyclone_rmws_are_refused_with_the_way_out(rmw: str) -> None:
    why = refusal_from_environment({"RMW_IMPLEMENTATION": rmw})
    assert why is not None and rmw in why and "RMW_IMPLEMENTATION=rmw_fastrtps_cpp" in why


@pytest.mark.parametrize("rmw", [None, "", "rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp", "rmw_zenoh_cpp"])
def test_other_rmws_pass(rmw: str | None) -> None:
    assert second_dds_stack(rmw) is None


def test_the_node_refuses_to_start_on_rmw_cyclonedds() -> None:
    env = {**os.environ, "RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}
    done = subprocess.run(python_module("g1_mode_manager.node.main"), env=env, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "refusing to start: RMW rmw_cyclonedds_cpp would load a second Cyclone DDS" in done.stderr, done.stderr
    assert "RMW_IMPLEMENTATION=rmw_fastrtps_cpp" in done.stderr
    assert "ready in" not in done.stdout + done.stderr  # it never came up
