"""Two robots at once: two sims on two SDK2 domains, two nodes in /g1_a and /g1_b on one ROS domain.

A mode request and a namespaced e-stop act on their own robot only; the global /estop stops both. Every
verdict is the robot's own: each sim's record (its requests and states), read from its file, because the
test process can join only one SDK2 domain. Two sims at once are heavy on two cores: both run at real
time with ROS publishing off, and the scenario is short.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from functools import partial

import pytest
from g1_mode_manager_msgs.srv import SetMode
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from support.domains import allocate_sdk_domain
from support.mode_manager import RosClient, start_mode_manager, wait_until
from support.processes import ManagedProcess
from support.sim_bridge import start_sim_bridge
from support.sim_record import SimRecord, damped, is_damp, requests, states


class Robot:
    """One sim + its node in a namespace, judged from the sim's record."""

    def __init__(self, ns: str, domain: int, record: SimRecord, bridge: ManagedProcess, ros: RosClient) -> None:
        self.ns, self.domain, self.record, self.bridge, self.ros = ns, domain, record, bridge, ros
        self.node: ManagedProcess | None = None

    def set_mode(self, name: str) -> SetMode.Response:
        return self.ros.call(SetMode, f"{self.ns}/g1_mode_manager/set_mode", SetMode.Request(mode_name=name))

    def estop(self) -> Trigger.Response:
        return self.ros.call(Trigger, f"{self.ns}/g1_mode_manager/estop", Trigger.Request())

    def state(self) -> dict:
        return states(self.record.events())[-1]

    def requests_since(self, t0: float) -> list[dict]:
        return requests(self.record.events(since=t0))

    def damps_since(self, t0: float) -> list[dict]:
        return [e for e in self.requests_since(t0) if is_damp(e)]


@pytest.fixture
def two_robots(sdk_channels: int, tmp_path):
    ros = RosClient("two_robots_client")
    robots: list[Robot] = []
    procs: list[ManagedProcess] = []
    try:
        # The two bridges start at once, then the two nodes at once: each start mostly waits (DDS discovery, the
        # bridge's model and policy load). Each node still starts after its robot's bridge is up, and every
        # process waits for its own ready line with its usual timeout; each one that came up is stopped below.
        layout = [(ns, domain, tmp_path / f"{ns.strip('/')}.jsonl")
                  for ns, domain in (("/g1_a", sdk_channels), ("/g1_b", allocate_sdk_domain()))]
        # hung in the gantry: one of them goes to LOW_LEVEL
        bridges = _start_together(procs, [partial(start_sim_bridge, domain, speed=1.0, extra_args=(
            "--record", str(path), "--no-ros-publish", "--gantry", "--ros-args", "-r", f"__ns:={ns}"))
            for ns, domain, path in layout])
        nodes = _start_together(procs, [partial(start_mode_manager, domain, remaps=(f"__ns:={ns}",))
                                        for ns, domain, _ in layout])
        for (ns, domain, path), bridge, node in zip(layout, bridges, nodes, strict=True):
            robots.append(Robot(ns, domain, SimRecord(path), bridge, ros))
            robots[-1].node = node
        for robot in robots:
            ros.wait_node_answers(f"{robot.ns}/g1_mode_manager")
        yield robots
    finally:
        ros.close()
        for proc in reversed(procs):
            code = proc.stop()
            if code not in (0, None):
                print(f"{proc.name} exited with {code}; output:\n{proc.output()[-3000:]}")


def _start_together(procs: list[ManagedProcess], starts: list) -> list[ManagedProcess]:
    """Run the ``starts`` at once; every process that came up joins ``procs`` (to be stopped), then the first
    failure is raised."""
    with ThreadPoolExecutor(max_workers=len(starts)) as pool:
        futures = [pool.submit(start) for start in starts]
    procs.extend(f.result() for f in futures if f.exception() is None)
    for f in futures:
        f.result()
    return [f.result() for f in futures]


def test_each_robot_obeys_its_own_node_and_the_global_estop_stops_both(two_robots) -> None:
    a, b = two_robots
    assert a.domain != b.domain
    assert a.state()["svc"] == b.state()["svc"] == "ai"  # both boot with the high-level service

    t0 = time.monotonic()
    r = a.set_mode("low_level")
    assert r.success, r.message
    assert a.state()["svc"] == ""  # robot A released its service ...
    assert b.state()["svc"] == "ai" and b.requests_since(t0) == []  # ... robot B heard nothing at all

    t1 = time.monotonic()
    r = b.set_mode("high_level")
    assert r.success, r.message
    assert b.requests_since(t1), "robot B never heard its own node"
    assert a.state()["svc"] == "" and a.damps_since(t0) == []

    t2 = time.monotonic()
    r = a.estop()
    assert r.success, r.message
    assert wait_until(lambda: damped(a.state()), 5.0), a.state()
    time.sleep(0.5)  # robot B's supervision keeps running: give a wrong Damp time to show up
    assert b.damps_since(t2) == [] and not damped(b.state()), b.state()

    t3 = time.monotonic()
    pub = ros_publisher(a.ros)
    assert wait_until(lambda: pub.get_subscription_count() >= 2, 10.0), "both nodes listen to /estop"
    # A message published right after the publisher saw both subscribers may still miss one whose own
    # side has not matched yet (BEST_EFFORT): an e-stop button keeps publishing while pressed.
    def press() -> bool:
        pub.publish(Bool(data=True))
        return damped(b.state())

    assert wait_until(press, 5.0, period_s=0.2), b.state()
    assert b.damps_since(t3), "robot B damped without a Damp request?"
    assert damped(a.state())


def ros_publisher(ros: RosClient):
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    return ros.node.create_publisher(Bool, "/estop", qos)
