"""Start the real mode_manager node in a subprocess for end-to-end tests, and a ROS client to drive it."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import rclpy
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

from g1_mode_manager.cli.client import call_client
from harness.processes import ManagedProcess, python_module


def start_mode_manager(sdk_domain: int, *params: str, ready_timeout_s: float = 30.0,
                       remaps: tuple[str, ...] = ()) -> ManagedProcess:
    """`python -m g1_mode_manager.node.main` on loopback and the given SDK domain; waits for its ready line.

    ``params`` are `name:=value` parameters, ``remaps`` `from:=to` remappings (e.g. `__ns:=/robot_a`). The suite's
    tests and the benchmarks were written for LOW_LEVEL by ReleaseMode: ``low_level_path:=release`` unless ``params``
    say otherwise.
    """
    args = ["--ros-args", "-p", f"dds_domain:={sdk_domain}", "-p", "network_interface:=lo"]
    if not any(p.startswith("low_level_path:=") for p in params):
        args += ["-p", "low_level_path:=release"]
    for p in params:
        args += ["-p", p]
    for r in remaps:
        args += ["-r", r]
    proc = ManagedProcess(python_module("g1_mode_manager.node.main", *args), name="mode_manager")
    proc.wait_for_line(lambda line: "ready in UNINITIALIZED" in line, ready_timeout_s)
    return proc


class RosClient:
    """A node in the test process, spun by its own executor thread."""

    def __init__(self, name: str = "e2e_client") -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node: Node = rclpy.create_node(name, context=self.context)
        self._clients: dict = {}
        self._clients_lock = threading.Lock()
        self._executor = MultiThreadedExecutor(num_threads=2, context=self.context)
        self._executor.add_node(self.node)
        # A waiting executor does not see entities created later until something wakes it: a no-op
        # timer wakes it every 0.1 s, so subscriptions added after the start are served too.
        self.node.create_timer(0.1, lambda: None)
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()

    def call(self, srv_type, name: str, request, timeout_s: float = 30.0, discovery_timeout_s: float = 15.0):
        """Call a service through a client made once per (type, name) and kept: destroying a client while
        this client's executor waits on it kills the executor's thread (rclpy InvalidHandle), and every
        later call then times out (seen with 8 threads calling at once)."""
        return call_client(self.client(srv_type, name), name, request, timeout_s, discovery_timeout_s)

    def client(self, srv_type, name: str):
        """The kept client of (``srv_type``, ``name``), made on first use."""
        with self._clients_lock:
            client = self._clients.get((srv_type, name))
            if client is None:
                client = self._clients[(srv_type, name)] = self.node.create_client(srv_type, name)
        return client

    def wait_node_answers(self, node_name: str = "/g1_mode_manager", timeout_s: float = 20.0) -> None:
        """Call the node's get_parameters service until it answers: once a request and its response
        have crossed, discovery between this client and the node is complete in both directions, so
        the next call is not lost to a half-matched service (seen right after a node restart)."""
        from rcl_interfaces.srv import GetParameters

        deadline = time.monotonic() + timeout_s
        call_timeout_s = 0.25  # a request lost to a half-matched service is retried soon, a slow machine
        while True:  # gets longer tries
            try:
                self.call(GetParameters, f"{node_name}/get_parameters", GetParameters.Request(names=["dds_domain"]),
                          timeout_s=call_timeout_s, discovery_timeout_s=5.0)
                return
            except TimeoutError:
                if time.monotonic() > deadline:
                    raise
                call_timeout_s = min(2.0, 2 * call_timeout_s)

    def service_present(self, name: str) -> bool:
        """A server of ``name`` is in the graph (the graph's service names also list clients: this
        client's own kept client of the service would keep it "present" forever)."""
        return self.node.count_services(name) > 0

    def wait_service_gone(self, name: str, timeout_s: float = 10.0) -> None:
        """After stopping a node: its service must leave the graph before a new node with the same
        name starts, or a new client may match the dead server and its request is lost."""
        if not wait_until(lambda: not self.service_present(name), timeout_s, period_s=0.05):
            raise TimeoutError(f"{name} is still served {timeout_s} s after its node stopped")

    def close(self) -> None:
        self._executor.shutdown()
        self._thread.join(5.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def wait_until(predicate: Callable[[], bool], timeout_s: float = 10.0, period_s: float = 0.02) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period_s)
    return predicate()
