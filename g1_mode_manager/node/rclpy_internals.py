"""The parts of rclpy below its public API that this project relies on, and nothing else.

rclpy's executors rebuild their wait set in Python on every wake; ``node/stream_taker.py`` serves a few
entities from a wait set of its own instead, which needs what the executors use internally: the C
binding's ``WaitSet`` (reached only through the private ``rclpy.impl.implementation_singleton``) and the
take calls of subscription and service handles. Every other module calls the functions here, so an
rclpy upgrade that changes them breaks this module only, and ``test/node/test_rclpy_internals.py``
names what changed. Written against rclpy 7.1 (Jazzy), where the executors make the same calls.
"""

from __future__ import annotations

from typing import Any

from rclpy.context import Context
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.service import Service
from rclpy.subscription import Subscription


def new_wait_set(context: Context, *, subscriptions: int, guard_conditions: int, services: int) -> Any:
    """An rcl wait set with room for that many entities (no timers, clients or events).

    Its calls are the binding's, used as the executors use them: ``clear_entities()``, ``add_subscription``,
    ``add_service``, ``add_guard_condition`` (each with an entity's ``handle``), ``wait(timeout_ns)``, and
    ``get_ready_entities(kind)``, the ``handle.pointer`` of each ready entity of that kind.
    """
    with context.handle:
        return _rclpy.WaitSet(subscriptions, guard_conditions, 0, 0, services, 0, context.handle)


def take_message(sub: Subscription) -> tuple[Any, Any] | None:
    """(the next message, its info) of a subscription, the message as CDR bytes if it is raw; None if none."""
    with sub.handle:
        return sub.handle.take_message(sub.msg_type, sub.raw)


def take_request(service: Service) -> Any:
    """(the next request, its header) of a service; the header is None if there was none."""
    with service.handle:
        return service.handle.service_take_request(service.srv_type.Request)
