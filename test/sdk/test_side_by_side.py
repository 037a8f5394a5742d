"""side_by_side: the SDK's constructor sleeps overlap, its DDS calls never do, results and errors come back in order."""

from __future__ import annotations

import threading
import time

import pytest

from g1_mode_manager.protocol.side_by_side import side_by_side


def _sdk_like(name: str, log: list[tuple[str, str]], inside: list[int], overlaps: list[str]):
    """A maker shaped like an SDK constructor: create (DDS calls), the SDK's own sleep, create again."""
    from unitree_sdk2py.rpc import client_stub  # the SDK module whose Init sleeps 0.5 s

    def create(step: str) -> None:
        inside.append(1)
        if len(inside) > 1:
            overlaps.append(f"{name} {step}")
        time.sleep(0.02)  # long enough for another thread to enter if nothing kept it out
        inside.pop()

    def make() -> str:
        create("before")
        log.append((name, "sleep"))
        client_stub.time.sleep(0.2)
        log.append((name, "woke"))
        create("after")
        return name

    return make


def test_the_sdk_sleeps_overlap_and_the_creations_never_do() -> None:
    log: list[tuple[str, str]] = []
    inside: list[int] = []
    overlaps: list[str] = []
    names = [f"maker{i}" for i in range(5)]
    assert side_by_side(*(_sdk_like(n, log, inside, overlaps) for n in names)) == names
    assert overlaps == []
    # every maker went to sleep before the first one woke: the five waits overlapped
    first_woke = log.index(next(e for e in log if e[1] == "woke"))
    assert {n for n, what in log[:first_woke] if what == "sleep"} == set(names)


def test_every_maker_runs_and_the_first_error_in_order_is_raised() -> None:
    ran: list[str] = []
    lock = threading.Lock()

    def ok(name: str):
        def make() -> str:
            with lock:
                ran.append(name)
            return name
        return make

    def fails(message: str):
        def make() -> None:
            with lock:
                ran.append(message)
            raise RuntimeError(message)
        return make

    with pytest.raises(RuntimeError, match="first"):
        side_by_side(ok("a"), fails("first"), ok("b"), fails("second"))
    assert sorted(ran) == ["a", "b", "first", "second"]


def test_an_sdk_sleep_outside_side_by_side_is_a_plain_sleep() -> None:
    from unitree_sdk2py.core import channel

    side_by_side()  # routes the SDK's sleeps
    started = time.monotonic()
    channel.time.sleep(0.05)
    assert time.monotonic() - started >= 0.05
    assert channel.time.monotonic is time.monotonic  # the rest of ``time`` is the standard one
