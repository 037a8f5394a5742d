"""Create the Unitree SDK2's DDS entities side by side, so that the SDK's built-in sleeps overlap.

The SDK's constructors sleep after creating their entities to let discovery happen: 0.5 s in each RPC client's
and server's stub, 0.2 s in each writer's Init. One after another, a node's two clients cost ~1.5 s and the sim's
five servers and seven publishers ~5 s. Here each maker runs in a thread of its own, but under one lock that
it gives up only while the SDK sleeps: the DDS calls stay one at a time, as before, and only the waits overlap.
One at a time matters: cyclonedds-python deadlocks when two threads create topics at once (one holds the
domain's lock and waits for the GIL to free a duplicate type, the other holds the GIL and waits for the lock).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from g1_mode_manager.protocol.unitree_sdk_internals import route_sdk_sleeps

_creating = threading.Lock()  # held by a maker except while the SDK sleeps in it
_mine = threading.local()
_routed = False
_routed_lock = threading.Lock()


def _sleep(seconds: float) -> None:
    """The SDK's sleep: inside a maker here, the lock is given to the others meanwhile."""
    if not getattr(_mine, "holding", False):
        time.sleep(seconds)
        return
    _mine.holding = False
    _creating.release()
    try:
        time.sleep(seconds)
    finally:
        _creating.acquire()
        _mine.holding = True


def _run(maker: Callable[[], Any]) -> Any:
    with _creating:
        _mine.holding = True
        try:
            return maker()
        finally:
            _mine.holding = False


def side_by_side(*makers: Callable[[], Any]) -> list[Any]:
    """Call every maker, each in a thread of its own, their SDK sleeps overlapping; results in the makers' order.

    Every maker runs to its end; the first exception (in the makers' order) is then raised.
    """
    global _routed
    with _routed_lock:
        if not _routed:
            route_sdk_sleeps(_sleep)
            _routed = True
    if not makers:
        return []
    with ThreadPoolExecutor(len(makers), thread_name_prefix="sdk_entity") as pool:
        futures = [pool.submit(_run, maker) for maker in makers]
    return [future.result() for future in futures]
