"""The parts of rclpy below its public API that this project relies on, and nothing else.

rclpy's executors rebuild their wait set in Python on every wake; ``node/stream_taker.py`` serves a few
entities from a wait set of its own instead, which needs what the executors use internally: the C
binding's ``WaitSet`` (reached only through the private ``rclpy.impl.implementation_singleton``), the
handles' pointers by which it names the ready entities, and the take calls of subscription and service
handles. Every other module calls the functions here, so an
rclpy upgrade that changes them breaks this module only, and ``test/node/test_rclpy_internals.py``
names what changed. Written against rclpy 7.1 (Jazzy), where the executors make the same calls.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rclpy.context import Context
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.service import Service
from rclpy.subscription import Subscription


class EntityWaitSet:
    """An rcl wait set of a fixed few subscriptions and services and one guard condition (no timers,
    clients or events), filled again before every wait as the executors do.

    The binding's calls are used as the executors use them: ``clear_entities()``, ``add_subscription``,
    ``add_service``, ``add_guard_condition`` (each with an entity's ``handle``), ``wait(timeout_ns)``, and
    ``get_ready_entities(kind)``, the ``handle.pointer`` of each ready entity of that kind.
    """

    def __init__(self, context: Context, *, subscriptions: Sequence[Subscription], services: Sequence[Service],
                 guard: GuardCondition) -> None:
        self._subs = tuple(subscriptions)
        self._services = tuple(services)
        self._guard = guard
        with context.handle:
            self._wait_set = _rclpy.WaitSet(len(self._subs), 1, 0, 0, len(self._services), 0, context.handle)

    def wait(self, timeout_ns: int) -> tuple[list[Service], list[Subscription]]:
        """Wait until an entity is ready, the guard is triggered or ``timeout_ns`` passed; the ready services
        and the ready subscriptions, each in the order given. Raises InvalidHandle once an entity or the
        context is gone."""
        wait_set = self._wait_set
        wait_set.clear_entities()
        for service in self._services:
            wait_set.add_service(service.handle)
        for sub in self._subs:
            wait_set.add_subscription(sub.handle)
        wait_set.add_guard_condition(self._guard.handle)
        wait_set.wait(timeout_ns)
        services: list[Service] = []
        if self._services:
            ready = wait_set.get_ready_entities("service")
            services = [service for service in self._services if service.handle.pointer in ready]
        ready = wait_set.get_ready_entities("subscription")
        return services, [sub for sub in self._subs if sub.handle.pointer in ready]


def take_message(sub: Subscription) -> tuple[Any, Any] | None:
    """(the next message, its info) of a subscription, the message as CDR bytes if it is raw; None if none."""
    with sub.handle:
        return sub.handle.take_message(sub.msg_type, sub.raw)


def take_request(service: Service) -> Any:
    """(the next request, its header) of a service; the header is None if there was none."""
    with service.handle:
        return service.handle.service_take_request(service.srv_type.Request)
