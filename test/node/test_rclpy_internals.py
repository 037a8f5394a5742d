"""The rclpy internals ``node/rclpy_internals.py`` relies on still exist and still work as its executors use them.

Each check names what changed, so an rclpy upgrade that breaks ``node/stream_taker.py`` fails here
first, with the place to fix. A real context and node on this run's own ROS domain (loopback).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import rclpy
from rclpy.node import Node
from rclpy.service import Service
from std_msgs.msg import String
from std_srvs.srv import Trigger

from g1_mode_manager.node.rclpy_internals import EntityWaitSet, take_message, take_request
from support.mode_manager import wait_until

HOME = "see g1_mode_manager/node/rclpy_internals.py"
WAIT_SET_CALLS = ("clear_entities", "add_subscription", "add_service", "add_guard_condition", "wait",
                  "get_ready_entities")


def changed(what: str) -> str:
    return f"rclpy changed: {what}; {HOME}"


@pytest.fixture
def node() -> Iterator[Node]:
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("rclpy_internals_probe", context=context)
    yield node
    node.destroy_node()
    rclpy.shutdown(context=context)


def test_the_binding_still_has_a_wait_set() -> None:
    from rclpy.impl import implementation_singleton

    binding = getattr(implementation_singleton, "rclpy_implementation", None)
    assert binding is not None, changed("rclpy.impl.implementation_singleton has no rclpy_implementation")
    assert hasattr(binding, "WaitSet"), changed("rclpy_implementation has no WaitSet")
    for call in WAIT_SET_CALLS:
        assert callable(getattr(binding.WaitSet, call, None)), changed(f"rclpy_implementation.WaitSet has no {call}")


def wait_ready(node: Node, entity, guard) -> bool:
    """One pass of the stream taker's loop for one subscription or service: is it ready within 5 s?"""
    is_service = isinstance(entity, Service)
    wait_set = EntityWaitSet(node.context, subscriptions=[] if is_service else [entity],
                             services=[entity] if is_service else [], guard=guard)
    services, subs = wait_set.wait(5_000_000_000)
    return (services if is_service else subs) == [entity]


def test_a_subscription_is_waited_for_and_taken(node: Node) -> None:
    received = node.create_subscription(String, "rclpy_internals_probe", lambda _msg: None, 10)
    raw = node.create_subscription(String, "rclpy_internals_probe", lambda _msg: None, 10, raw=True)
    guard = node.create_guard_condition(lambda: None)
    publisher = node.create_publisher(String, "rclpy_internals_probe", 10)
    assert wait_until(lambda: publisher.get_subscription_count() >= 2, 10.0)
    publisher.publish(String(data="probe"))
    assert wait_ready(node, received, guard), changed("a WaitSet never saw a published message")
    taken = take_message(received)
    assert taken is not None and taken[0] == String(data="probe"), changed(f"Subscription.handle.take_message: {taken!r}")
    assert take_message(received) is None, changed("take_message of an empty subscription is not None")
    assert wait_ready(node, raw, guard)
    taken = take_message(raw)
    assert taken is not None and isinstance(taken[0], bytes), changed("a raw subscription's take_message is not bytes")


def test_a_service_request_is_waited_for_and_taken(node: Node) -> None:
    service = node.create_service(Trigger, "rclpy_internals_probe", lambda _request, response: response)
    guard = node.create_guard_condition(lambda: None)
    client = node.create_client(Trigger, "rclpy_internals_probe")
    assert client.wait_for_service(timeout_sec=10.0)
    client.call_async(Trigger.Request())
    assert wait_ready(node, service, guard), changed("a WaitSet never saw a service request")
    request, header = take_request(service)
    assert isinstance(request, Trigger.Request) and header is not None, changed(
        "Service.handle.service_take_request is not (request, header)")
    _request, header = take_request(service)
    assert header is None, changed("service_take_request of an empty service has a header")
