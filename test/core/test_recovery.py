"""The recovery sequence of g1ctl recover and the console's Recover, without ROS: HIGH_LEVEL if needed, damp, the
get-up the settled posture calls for, balance stand; each on its verified answer, stopping at the first failure,
each result told as soon as it is known, refused with the reason before anything is sent."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

from g1_mode_manager.core.recovery import STEPS, recover


@dataclass
class Answer:
    success: bool
    message: str


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.t += s


@dataclass
class Robot:
    """A node whose posture follows a script of (from time, posture) once damped."""

    clock: Clock
    mode_name: str = "IDLE"
    posture: str = "lying_back"
    after_damp: list[tuple[float, str]] = field(default_factory=list)
    fail: dict[str, str] = field(default_factory=dict)
    asked: list[str] = field(default_factory=list)
    damped_at: float | None = None

    def mode(self) -> tuple[str, str] | None:
        posture = self.posture
        if self.damped_at is not None:
            for since, p in self.after_damp:
                if self.clock.t - self.damped_at >= since:
                    posture = p
        return self.mode_name, posture

    def set_mode(self, mode: str) -> Answer:
        self.asked.append(f"set_mode {mode}")
        if mode in self.fail:
            return Answer(False, self.fail[mode])
        self.mode_name = mode
        return Answer(True, f"{mode}: done")

    def loco(self, verb: str) -> Answer:
        self.asked.append(verb)
        if verb in self.fail:
            return Answer(False, self.fail[verb])
        if verb == "damp":
            self.damped_at = self.clock.t
        return Answer(True, f"{verb}: done")


def _run(robot: Robot, **kwargs):
    return recover(robot, clock=robot.clock, sleep=robot.clock.sleep, **kwargs)


def test_a_lying_robot_in_idle_gets_high_level_damp_lie_to_stand_and_balance_stand() -> None:
    robot = Robot(Clock(), "IDLE", "lying_back", after_damp=[(0.0, "lying_back")])
    results = _run(robot)
    assert robot.asked == ["set_mode HIGH_LEVEL", "damp", "lie_to_stand", "balance_stand"]
    assert [r.step for r in results] == list(STEPS) and all(r.success for r in results)
    assert results[2].message.startswith("lie_to_stand (lying_back)")


def test_a_robot_folded_in_a_squat_gets_squat_to_stand_the_vendors_power_on_flow() -> None:
    robot = Robot(Clock(), "HIGH_LEVEL", "squatting", after_damp=[(0.0, "squatting")])
    results = _run(robot)
    assert robot.asked == ["damp", "squat_to_stand", "balance_stand"]
    assert results[0].message == "in HIGH_LEVEL already" and all(r.success for r in results)


def test_a_node_just_started_asks_for_high_level_first() -> None:
    robot = Robot(Clock(), "UNINITIALIZED", "squatting", after_damp=[(0.0, "squatting")])
    assert all(r.success for r in _run(robot))
    assert robot.asked == ["set_mode HIGH_LEVEL", "damp", "squat_to_stand", "balance_stand"]


def test_the_get_up_waits_for_the_damped_robot_to_settle() -> None:
    """Falling from a crouch, a damped robot passes through a squat's knees before it lies: a reading that does not
    last is not a posture to get up from."""
    robot = Robot(Clock(), "HIGH_LEVEL", "unknown",
                  after_damp=[(0.0, "unknown"), (0.3, "squatting"), (0.6, "unknown"), (1.2, "lying_back")])
    results = _run(robot)
    assert robot.asked == ["damp", "lie_to_stand", "balance_stand"]
    assert results[2].took_s >= 1.7  # lying from 1.2 s, then read for 0.5 s


def test_a_robot_that_settles_in_no_posture_a_get_up_fits_is_not_sent_one() -> None:
    robot = Robot(Clock(), "HIGH_LEVEL", "unknown", after_damp=[(0.0, "unknown")])
    results = _run(robot, settle_wait_s=2.0)
    assert robot.asked == ["damp"]
    assert not results[-1].success and results[-1].step == "get_up" and "posture unknown" in results[-1].message


@pytest.mark.parametrize(("mode", "posture", "why"), [
    ("FAULT", "lying_back", "clear_fault first"),
    ("EMERGENCY", "lying_back", "never left"),
    ("LOW_LEVEL", "standing", "starts from UNINITIALIZED, IDLE or HIGH_LEVEL"),
    ("HIGH_LEVEL", "standing", "stands already"),
    ("IDLE", "hanging", "on the gantry use stand_up"),
])
def test_refused_before_anything_is_sent(mode: str, posture: str, why: str) -> None:
    robot = Robot(Clock(), mode, posture)
    results = _run(robot)
    assert robot.asked == []
    assert len(results) == 1 and not results[0].success and why in results[0].message


def test_no_mode_yet_is_refused() -> None:
    class Silent(Robot):
        def mode(self) -> None:
            return None

    robot = Silent(Clock())
    results = _run(robot)
    assert robot.asked == [] and "no ~/mode" in results[0].message


def test_it_stops_at_the_first_failure_with_what_the_robot_showed() -> None:
    robot = Robot(Clock(), "HIGH_LEVEL", "lying_back", after_damp=[(0.0, "lying_back")],
                  fail={"lie_to_stand": "code 0, preempted by e-stop after 1.20 s (the robot showed fsm 702)"})
    results = _run(robot)
    assert robot.asked == ["damp", "lie_to_stand"]
    assert [r.step for r in results] == ["high_level", "damp", "get_up"] and not results[-1].success
    assert "preempted by e-stop" in results[-1].message


def test_a_refused_high_level_ends_it() -> None:
    robot = Robot(Clock(), "IDLE", "lying_back", fail={"HIGH_LEVEL": "the robot's service did not answer"})
    results = _run(robot)
    assert robot.asked == ["set_mode HIGH_LEVEL"] and not results[-1].success


def test_each_result_is_told_before_the_next_step_is_asked() -> None:
    robot = Robot(Clock(), "IDLE", "lying_back", after_damp=[(0.0, "lying_back")], fail={"balance_stand": "code 3104"})
    told: list[tuple[str, list[str]]] = []
    _run(robot, on_step=lambda r: told.append((r.step, list(robot.asked))))
    assert told == [("high_level", ["set_mode HIGH_LEVEL"]), ("damp", ["set_mode HIGH_LEVEL", "damp"]),
                    ("get_up", ["set_mode HIGH_LEVEL", "damp", "lie_to_stand"]),
                    ("balance_stand", ["set_mode HIGH_LEVEL", "damp", "lie_to_stand", "balance_stand"])]
