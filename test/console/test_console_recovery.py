"""The Recover button's runner without ROS: the sequence runs beside the event loop (which goes on serving while a
step waits), every page is told each step as it is asked and answered and then the end, the step that failed
with what the node said; a second start while one runs is refused with who runs which step, never queued."""

from __future__ import annotations

import asyncio
from typing import Any

from g1_mode_manager.console.recovery import RecoveryRunner

DONE = {"success": True, "code": 0, "outcome_s": 0.1}


class Node:
    """~/set_mode and ~/loco_command as the runner's ask sees them: an answer per call (the mode asked, or the verb);
    a held call waits until released. ~/mode: IDLE, then HIGH_LEVEL once asked; the robot lies throughout."""

    def __init__(self, answers: dict[str, dict[str, Any]], held: str = "") -> None:
        self.answers = {"HIGH_LEVEL": {"success": True, "message": "HIGH_LEVEL: done"}, **answers}
        self.held = held
        self.release = asyncio.Event()
        self.asked: list[str] = []
        self.name = "IDLE"

    async def ask(self, service: str, argument: str) -> dict[str, Any]:
        self.asked.append(argument)
        if argument == self.held:
            await self.release.wait()
        answer = self.answers[argument]
        if service == "set_mode" and answer["success"]:
            self.name = argument
        return answer

    def mode(self) -> tuple[str, str]:
        return self.name, "lying_back"


async def _until(predicate, timeout_s: float = 5.0) -> None:
    async def poll() -> None:
        while not predicate():
            await asyncio.sleep(0.005)

    await asyncio.wait_for(poll(), timeout_s)


def test_each_step_is_told_the_loop_serves_meanwhile_and_a_second_start_is_refused() -> None:
    async def go() -> None:
        node = Node({s: {**DONE, "message": f"{s}: done"} for s in ("damp", "lie_to_stand", "balance_stand")},
                    held="lie_to_stand")
        told: list[dict[str, Any]] = []
        runner = RecoveryRunner(node.ask, told.append, node.mode)
        assert runner.start("console 1") is None
        await _until(lambda: node.asked == ["HIGH_LEVEL", "damp", "lie_to_stand"])
        ticks = 0
        for _ in range(20):  # the loop is free while the get-up's answer is awaited
            await asyncio.sleep(0.005)
            ticks += 1
        assert ticks == 20 and runner.status()["step"] == "get_up"
        refused = runner.start("console 2")
        assert refused and "already running" in refused and "console 1" in refused and "get_up" in refused
        node.release.set()
        await _until(lambda: told and told[-1]["event"] == "done")
        assert [(e["event"], e.get("step")) for e in told] == [
            ("started", None), ("step", "high_level"), ("result", "high_level"), ("step", "damp"), ("result", "damp"),
            ("step", "get_up"), ("result", "get_up"), ("step", "balance_stand"), ("result", "balance_stand"),
            ("done", None)]
        assert all(e["by"] == "console 1" for e in told)
        assert told[-1]["success"] and told[-1]["message"] == "the robot stands" and told[-1]["failed_step"] is None
        assert node.asked == ["HIGH_LEVEL", "damp", "lie_to_stand", "balance_stand"], "the refused start was queued"
        node.name = "IDLE"
        assert runner.status() is None and runner.start("console 2") is None  # over: a new one may start
        await _until(lambda: told[-1]["event"] == "done" and told[-1]["by"] == "console 2")

    asyncio.run(go())


def test_the_first_failed_step_ends_it_with_what_the_node_said() -> None:
    preempted = {"success": False, "code": 0, "outcome_s": -1.0,
                 "message": "lie_to_stand: code 0, preempted by e-stop after 1.20 s (the robot showed fsm 702)"}

    async def go() -> None:
        node = Node({"damp": {**DONE, "message": "damp: done"}, "lie_to_stand": preempted})
        told: list[dict[str, Any]] = []
        assert RecoveryRunner(node.ask, told.append, node.mode).start("console 1") is None
        await _until(lambda: told and told[-1]["event"] == "done")
        failed = [e for e in told if e["event"] == "result" and not e["success"]]
        assert [e["step"] for e in failed] == ["get_up"]
        assert failed[0]["message"] == f"lie_to_stand (lying_back): {preempted['message']}"
        end = told[-1]
        assert not end["success"] and end["failed_step"] == "get_up" and "preempted by e-stop" in end["message"]
        assert node.asked == ["HIGH_LEVEL", "damp", "lie_to_stand"]

    asyncio.run(go())


def test_a_call_the_node_never_took_fails_the_step_that_needed_it() -> None:
    async def go() -> None:
        node = Node({"damp": {"success": False, "message": "not sent: /g1_mode_manager/loco_command is not available"}})
        told: list[dict[str, Any]] = []
        assert RecoveryRunner(node.ask, told.append, node.mode).start("console 1") is None
        await _until(lambda: told and told[-1]["event"] == "done")
        assert told[-1]["failed_step"] == "damp" and "not available" in told[-1]["message"]

    asyncio.run(go())
