"""Serve a few subscriptions (and services) from one thread of their own, through a wait set of just those.

rclpy's executors rebuild their wait set in Python on every wake (every subscription, timer,
service, guard and publisher event handler of every node, through context managers), which at 100 Hz
of /cmd_vel adds up to a noticeable share of a core, and a service request then waits for a hand-off
to a pool thread. Here the wait set holds only the given
subscriptions and services and a stop guard; each wake costs a few C calls, one take per ready entity,
and the callback. Callbacks run one at a time in this thread: they must not block (the relays only
store the command and wake their worker; a service callback hands its slow part to a thread of its
own and answers from there through ``respond``).

The wait set and the takes are rclpy's own, as its executors use them (``rclpy_internals.py``).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

from rclpy.exceptions import InvalidHandle
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.service import Service
from rclpy.subscription import Subscription

from g1_mode_manager.node.rclpy_internals import EntityWaitSet, take_message, take_request

_log = logging.getLogger(__name__)
#: The thread looks at its stop flag at least this often (ns): a stop after SIGINT cannot use the guard.
WAIT_PERIOD_NS = 250_000_000

Respond = Callable[[Any], None]


class StreamTaker:
    """Subscriptions and services on ``node`` (never added to an executor), served by ``start()``'s thread."""

    def __init__(self, node: Node, name: str = "stream_taker",
                 on_error: Callable[[BaseException], None] | None = None) -> None:
        self._node = node
        self._subs: list[Subscription] = []
        self._services: list[tuple[Service, Callable[[Any, Respond], None]]] = []
        self._on_error = on_error
        self._stop = threading.Event()
        self._guard = node.create_guard_condition(lambda: None)
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def subscribe(self, msg_type: Any, topic: str, callback: Callable[[Any], None],
                  qos: QoSProfile | int = 10, *, raw: bool = False) -> Subscription:
        """Create a subscription served by this thread (before ``start()``). ``raw``: the callback gets the
        serialised message (CDR bytes) instead of a message object."""
        if self._thread.is_alive():
            raise RuntimeError("subscribe before start()")
        sub = self._node.create_subscription(msg_type, topic, callback, qos, raw=raw)
        self._subs.append(sub)
        return sub

    def serve(self, srv_type: Any, name: str, callback: Callable[[Any, Respond], None]) -> Service:
        """Create a service served by this thread (before ``start()``): ``callback(request, respond)`` runs
        here; ``respond(response)`` sends the answer, from any thread, once."""
        if self._thread.is_alive():
            raise RuntimeError("serve before start()")
        service = self._node.create_service(srv_type, name, lambda _request, response: response)  # never called
        self._services.append((service, callback))
        return service

    def start(self) -> None:
        self._thread.start()

    def shutdown(self, timeout_s: float = 3.0) -> None:
        self._stop.set()
        if not self._node.context.ok():
            # SIGINT already shut the context down: triggering its guard condition now crashes in rcl
            # (SIGSEGV, seen in the chaos suite); the thread sees the stop flag within one wait period.
            self._thread.join(timeout_s)
            return
        try:
            self._guard.trigger()
        except InvalidHandle:
            pass
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def _run(self) -> None:
        context = self._node.context
        try:
            wait_set = EntityWaitSet(context, subscriptions=self._subs,
                                     services=[service for service, _callback in self._services], guard=self._guard)
            while not self._stop.is_set() and context.ok():
                ready_services, ready_subs = wait_set.wait(WAIT_PERIOD_NS)
                for service, callback in self._services:  # services first: they are the e-stop's
                    if service in ready_services:
                        self._take_request(service, callback)
                for sub in ready_subs:
                    self._take(sub)
        except InvalidHandle:  # the node or the context went away: shutting down
            return
        except Exception as exc:  # reported, and the streams stop: never silently
            _log.exception("stream taker stopped")
            if self._on_error is not None:
                self._on_error(exc)

    def _take_request(self, service: Service, callback: Callable[[Any, Respond], None]) -> None:
        request, header = take_request(service)
        if header is None:
            return

        def respond(response: Any) -> None:
            try:
                service.send_response(response, header)
            except InvalidHandle:  # the node went away meanwhile: shutting down, nobody to answer
                pass

        try:
            callback(request, respond)
        except Exception as exc:  # a callback bug must not end the thread
            if self._on_error is not None:
                self._on_error(exc)

    def _take(self, sub: Subscription) -> None:
        taken = take_message(sub)
        if taken is None:
            return
        try:
            sub.callback(taken[0])
        except Exception as exc:  # a callback bug must not end the streams
            if self._on_error is not None:
                self._on_error(exc)
