"""The recovery sequence of g1ctl recover and the console's Recover, without ROS: the steps in order, each on its
verified answer, stopping at the first failure, each result told as soon as it is known."""

from __future__ import annotations

from dataclasses import dataclass

from g1_mode_manager.core.recovery import recover


@dataclass
class Answer:
    success: bool
    message: str
    code: int = 0
    outcome_s: float = 0.0


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.t += s


def _loco(answers: dict[str, list[Answer]], asked: list[str]):
    def loco(step: str) -> Answer:
        asked.append(step)
        queue = answers[step]
        return queue.pop(0) if len(queue) > 1 else queue[0]
    return loco


def test_the_three_steps_in_order_and_lie_to_stand_asked_again_until_the_robot_lies() -> None:
    asked: list[str] = []
    not_yet = Answer(False, "the robot is not lying (tilt 0.40 rad, lying is above 1.0): ...", -1)
    loco = _loco({"damp": [Answer(True, "damp: done")],
                  "lie_to_stand": [not_yet, not_yet, Answer(True, "lie_to_stand: done, the robot shows fsm 702")],
                  "balance_stand": [Answer(True, "balance_stand: done")]}, asked)
    clock = Clock()
    results = recover(loco, clock=clock, sleep=clock.sleep)
    assert asked == ["damp", "lie_to_stand", "lie_to_stand", "lie_to_stand", "balance_stand"]
    assert [r.success for r in results] == [True, True, True]
    assert results[1].took_s == 0.5


def test_it_stops_at_the_first_failure_with_what_the_robot_showed() -> None:
    asked: list[str] = []
    loco = _loco({"damp": [Answer(True, "damp: done")],
                  "lie_to_stand": [Answer(False, "lie_to_stand: code 0, preempted by e-stop after 1.20 s "
                                                 "(the robot showed fsm 702 (fsm_mode 1, still moving))", 0)],
                  "balance_stand": [Answer(True, "never asked")]}, asked)
    results = recover(loco, clock=Clock())
    assert asked == ["damp", "lie_to_stand"]
    assert [r.step for r in results] == ["damp", "lie_to_stand"] and not results[-1].success
    assert "preempted by e-stop" in results[-1].message


def test_a_robot_that_never_lies_gives_lie_to_stand_up_after_the_wait() -> None:
    asked: list[str] = []
    loco = _loco({"damp": [Answer(True, "damp: done")],
                  "lie_to_stand": [Answer(False, "the robot is not lying (tilt 0.10 rad ...)", -1)],
                  "balance_stand": [Answer(True, "never asked")]}, asked)
    clock = Clock()
    results = recover(loco, clock=clock, sleep=clock.sleep, lying_wait_s=1.0)
    assert not results[-1].success and results[-1].step == "lie_to_stand" and asked.count("balance_stand") == 0
    assert asked.count("lie_to_stand") == 5  # the first ask and one every 0.25 s until 1 s had passed


def test_each_result_is_told_before_the_next_step_is_asked() -> None:
    asked: list[str] = []
    told: list[tuple[str, list[str]]] = []
    loco = _loco({"damp": [Answer(True, "damp: done")], "lie_to_stand": [Answer(True, "lie_to_stand: done")],
                  "balance_stand": [Answer(False, "balance_stand: code 3104")]}, asked)
    results = recover(loco, clock=Clock(), on_step=lambda r: told.append((r.step, list(asked))))
    assert told == [("damp", ["damp"]), ("lie_to_stand", ["damp", "lie_to_stand"]),
                    ("balance_stand", ["damp", "lie_to_stand", "balance_stand"])]
    assert [r.step for r in results] == ["damp", "lie_to_stand", "balance_stand"] and not results[-1].success
