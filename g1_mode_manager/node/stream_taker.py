"""Serve a few subscriptions from one thread of their own, through a wait set of just those.

rclpy's executors rebuild their wait set in Python on every wake (every subscription, timer,
service, guard and publisher event handler of every node, through context managers): on this
project's machine ~0.6-0.9 ms per /cmd_vel message, 6-9 % of a core at 100 Hz. Here the wait set
holds only the command subscriptions and a stop guard; each wake costs a few C calls, one take per
ready subscription, and the callback. Callbacks run one at a time in this thread: they must not
block (the relays only store the command and wake their worker).

Uses rclpy's wait set and take calls as its executors do (rclpy 7.1, Jazzy).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

from rclpy.exceptions import InvalidHandle
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription

_log = logging.getLogger(__name__)
#: The thread looks at its stop flag at least this often (ns): a stop after SIGINT cannot use the guard.
WAIT_PERIOD_NS = 100_000_000


class StreamTaker:
    """Subscriptions on ``node`` (never added to an executor), served by ``start()``'s thread."""

    def __init__(self, node: Node, name: str = "stream_taker",
                 on_error: Callable[[BaseException], None] | None = None) -> None:  # fmt: skip
        self._node = node
        self._subs: list[Subscription] = []
        self._on_error = on_error
        self._stop = threading.Event()
        self._guard = node.create_guard_condition(lambda: None)
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def subscribe(self, msg_type: Any, topic: str, callback: Callable[[Any], None],
                  qos: QoSProfile | int = 10) -> Subscription:  # fmt: skip
        """Create a subscription served by this thread (before ``start()``)."""
        if self._thread.is_alive():
            raise RuntimeError("subscribe before start()")
        sub = self._node.create_subscription(msg_type, topic, callback, qos)
        self._subs.append(sub)
        return sub

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
            with context.handle:
                wait_set = _rclpy.WaitSet(len(self._subs), 1, 0, 0, 0, 0, context.handle)
            while not self._stop.is_set() and context.ok():
                wait_set.clear_entities()
                for sub in self._subs:
                    wait_set.add_subscription(sub.handle)
                wait_set.add_guard_condition(self._guard.handle)
                wait_set.wait(WAIT_PERIOD_NS)
                ready = wait_set.get_ready_entities("subscription")
                for sub in self._subs:
                    if sub.handle.pointer in ready:
                        self._take(sub)
        except InvalidHandle:  # the node or the context went away: shutting down
            return
        except Exception as exc:  # reported, and the streams stop: never silently
            _log.exception("stream taker stopped")
            if self._on_error is not None:
                self._on_error(exc)

    def _take(self, sub: Subscription) -> None:
        with sub.handle:
            taken = sub.handle.take_message(sub.msg_type, sub.raw)
        if taken is None:
            return
        try:
            sub.callback(taken[0])
        except Exception as exc:  # a callback bug must not end the streams
            if self._on_error is not None:
                self._on_error(exc)
