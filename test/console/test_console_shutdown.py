"""A change the ROS thread reports reaches the console's loop while it runs, and is dropped without an error once
the loop is closed (an answer that lands while the console shuts down)."""

from __future__ import annotations

import asyncio
import threading

from g1_mode_manager.console.main import call_in_loop


def test_a_change_from_another_thread_runs_in_the_loop() -> None:
    ran: list[threading.Thread] = []

    async def serve() -> None:
        loop = asyncio.get_running_loop()
        done = asyncio.Event()

        def changed() -> None:
            ran.append(threading.current_thread())
            done.set()

        threading.Thread(target=call_in_loop, args=(loop, changed)).start()
        await asyncio.wait_for(done.wait(), 5.0)

    asyncio.run(serve())
    assert ran == [threading.main_thread()]


def test_a_change_after_the_loop_closed_is_dropped_without_an_error() -> None:
    loop = asyncio.new_event_loop()
    loop.close()
    ran: list[int] = []
    call_in_loop(loop, lambda: ran.append(1))  # the executor's thread: must not raise
    assert ran == []
