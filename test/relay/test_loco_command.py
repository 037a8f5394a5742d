"""~/loco_command without ROS on the fake port: what each verb sends, when it is refused, and that it is answered
on the outcome the robot shows, not on the return code."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.relay.loco_command import LocoCommands, LocoResult


class Gate:
    """A mode machine stand-in: a mode, and whether robot_call lets a call through (an e-stop began)."""

    def __init__(self, mode: Mode = Mode.HIGH_LEVEL, open_: bool = True) -> None:
        self.mode = mode
        self.open = open_

    @contextmanager
    def robot_call(self, allowed: Callable[[Mode], bool]) -> Iterator[bool]:
        yield self.open and allowed(self.mode)


def run_loco_command(port: FakeRobotPort, gate: Gate, command: str, value: int, *,
                     timeout_s: float = 0.3) -> LocoResult:
    return LocoCommands(port, gate, outcome_timeout_s=timeout_s, motion_timeout_s=timeout_s).run(command, value)


SURFACE = [
    ("high_stand", 0, ("high_stand", ())),
    ("low_stand", 0, ("low_stand", ())),
    ("wave_hand", 0, ("set_arm_task", (0,))),
    ("wave_and_turn", 0, ("set_arm_task", (1,))),
    ("shake_hand", 0, ("set_arm_task", (2,))),
    ("shake_hand", 1, ("set_arm_task", (3,))),
]

#: Posture verbs: the robot's fsm ids and balance modes. Not in SURFACE, whose verbs must be refused outside
#: HIGH_LEVEL: damp passes there too.
POSTURE = [
    ("damp", 0, ("set_fsm_id", (1,))),
    ("zero_torque", 0, ("set_fsm_id", (0,))),
    ("squat", 0, ("set_fsm_id", (2,))),
    ("sit", 0, ("set_fsm_id", (3,))),
    ("stand_up", 0, ("set_fsm_id", (4,))),
    ("squat_to_stand", 0, ("set_fsm_id", (706,))),
    ("stand_to_squat", 0, ("set_fsm_id", (706,))),
    ("start", 0, ("set_fsm_id", (500,))),
    ("balance_stand", 0, ("set_balance_mode", (0,))),
    ("continuous_gait", 1, ("set_balance_mode", (1,))),
    ("continuous_gait", 0, ("set_balance_mode", (0,))),
    ("speed_mode", 3, ("set_speed_mode", (3,))),
]


@pytest.mark.parametrize(("command", "value", "sent"), SURFACE + POSTURE)
def test_each_command_sends_its_call_in_high_level_while_static(command: str, value: int, sent: tuple) -> None:
    port = FakeRobotPort()
    result = run_loco_command(port, Gate(), command, value)
    assert result.success and result.code == 0, result.message
    assert [(s.name, s.args) for s in port.sent] == [sent]
    if command == "speed_mode":  # nothing on the robot to read it back from: said, and no outcome time
        assert "not verified" in result.message and result.outcome_s == -1.0
    else:
        assert "done, the robot shows" in result.message and 0.0 < result.outcome_s < 0.3, result


@pytest.mark.parametrize(("command", "value", "sent"), [c for c in SURFACE + POSTURE if c[0] != "speed_mode"])
def test_each_command_fails_with_code_0_when_the_robot_does_not_show_its_outcome(command: str, value: int,
                                                                                 sent: tuple) -> None:
    port = FakeRobotPort()
    port.balance_mode = 1 - value if command == "continuous_gait" else 1  # so that a change would show
    if command == "stand_up":  # asking for the fsm the robot is in is its own outcome: start elsewhere
        port.sport = SportState(fsm_id=500, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)
    port.outcomes = False
    started = time.monotonic()
    result = run_loco_command(port, Gate(), command, value, timeout_s=0.2)
    waited = time.monotonic() - started
    assert not result.success and result.code == 0 and result.outcome_s == -1.0, result
    assert "but the robot showed" in result.message and "for 0.2 s" in result.message, result.message
    assert waited >= 0.2
    assert [(s.name, s.args) for s in port.sent] == [sent]


def test_start_ignored_by_the_firmware_answers_false_with_the_fsm_it_saw() -> None:
    port = FakeRobotPort()
    port.ignored_fsm_ids = {500}
    result = run_loco_command(port, Gate(), "start", 0, timeout_s=0.2)
    assert not result.success and result.code == 0
    assert result.message == "start: code 0, but the robot showed fsm 4 (fsm_mode 0) for 0.2 s"


def test_a_state_from_before_the_send_does_not_count_as_the_outcome() -> None:
    port = FakeRobotPort()
    port.sport = SportState(fsm_id=1, fsm_mode=0, task_id=0, task_time=0.0, age_s=5.0)  # damped, but stale
    port.outcomes = False
    result = run_loco_command(port, Gate(Mode.IDLE), "damp", 0, timeout_s=0.2)
    assert not result.success and "nothing yet" in result.message, result.message


def test_a_task_that_began_before_the_send_is_not_its_outcome() -> None:
    port = FakeRobotPort()
    port.sport = SportState(fsm_id=500, fsm_mode=0, task_id=0, task_time=1.5, age_s=0.01)  # a wave half played
    port.outcomes = False
    result = run_loco_command(port, Gate(), "wave_hand", 0, timeout_s=0.2)
    assert not result.success and "task 0 at 1.50 s" in result.message, result.message


def test_a_stand_height_already_at_a_verified_extreme_counts_without_moving() -> None:
    port = FakeRobotPort()
    commands = LocoCommands(port, Gate(), outcome_timeout_s=0.2, motion_timeout_s=0.2)
    first = commands.run("high_stand", 0)
    assert first.success, first.message
    again = commands.run("high_stand", 0)  # 0.78 -> 0.78: the extreme the first one verified
    assert again.success and "stand height 0.780 (before: 0.780)" in again.message, again.message
    unknown = run_loco_command(port, Gate(), "high_stand", 0, timeout_s=0.2)  # a fresh service knows no extreme
    assert not unknown.success, unknown.message


@pytest.mark.parametrize(("target", "reason"), [(Mode.EMERGENCY, "preempted by e-stop"),
                                                (Mode.IDLE, "preempted: mode HIGH_LEVEL -> IDLE")])
def test_a_mode_change_preempts_a_command_waiting_for_its_outcome(target: Mode, reason: str) -> None:
    port = FakeRobotPort()
    port.outcomes = False
    commands = LocoCommands(port, Gate(), outcome_timeout_s=5.0, motion_timeout_s=5.0)
    results: list[LocoResult] = []
    waiter = threading.Thread(target=lambda: results.append(commands.run("start", 0)))
    waiter.start()
    deadline = time.monotonic() + 2.0
    while not port.sent and time.monotonic() < deadline:
        time.sleep(0.005)
    time.sleep(0.05)  # well inside the wait
    left = time.monotonic()
    commands.on_leave(Mode.HIGH_LEVEL, target)
    waiter.join(2.0)
    assert results, "the command was not answered"
    assert time.monotonic() - left < 0.5  # answered at once, not at the 5 s limit
    result = results[0]
    assert not result.success and result.code == 0 and reason in result.message, result.message


@pytest.mark.parametrize("command", sorted({c for c, _, _ in SURFACE}))
def test_refused_outside_high_level_while_dynamic_or_once_an_estop_began(command: str) -> None:
    for gate, sport in ((Gate(Mode.IDLE), None), (Gate(Mode.LOW_LEVEL), None), (Gate(open_=False), None),
                        (Gate(), SportState(fsm_id=500, fsm_mode=1, task_id=0, task_time=0.0, age_s=0.01))):
        port = FakeRobotPort()
        if sport is not None:
            port.sport = sport
        result = run_loco_command(port, gate, command, 0)
        assert not result.success and result.code == -1, (gate.mode, result.message)
        assert port.sent == []


@pytest.mark.parametrize(("command", "value", "needle"), [
    ("continuous_gait", 2, "value from 0 to 1"), ("speed_mode", 4, "value from 0 to 3"), ("fly", 0, "unknown command"),
])
def test_values_out_of_range_and_unknown_verbs_are_refused_unsent(command: str, value: int, needle: str) -> None:
    port = FakeRobotPort()
    result = run_loco_command(port, Gate(), command, value)
    assert not result.success and needle in result.message and port.sent == []


def test_shake_hand_takes_only_its_two_stages() -> None:
    port = FakeRobotPort()
    result = run_loco_command(port, Gate(), "shake_hand", 2)
    assert not result.success and "value from 0 to 1" in result.message and port.sent == []


def _damped_lying(port: FakeRobotPort) -> None:
    port.sport = SportState(fsm_id=1, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)


def test_lie_to_stand_sends_702_damped_and_lying_and_is_answered_on_702_static_with_the_robot_up() -> None:
    port = FakeRobotPort()
    _damped_lying(port)
    tilts = iter([1.8] + [0.05] * 100)  # lying when asked, up once 702 shows
    result = LocoCommands(port, Gate(), outcome_timeout_s=0.2, motion_timeout_s=0.2, get_up_timeout_s=0.3,
                          tilt=lambda: next(tilts)).run("lie_to_stand", 0)
    assert result.success and [(s.name, s.args) for s in port.sent] == [("set_fsm_id", (702,))], result.message
    assert "the robot shows fsm 702 (fsm_mode 0), tilt 0.05 rad" in result.message


def test_702_static_with_the_robot_still_on_the_floor_is_not_a_get_up() -> None:
    port = FakeRobotPort()
    _damped_lying(port)
    result = LocoCommands(port, Gate(), outcome_timeout_s=0.1, motion_timeout_s=0.1, get_up_timeout_s=0.3,
                          tilt=lambda: 1.8).run("lie_to_stand", 0)
    assert not result.success and result.message == (
        "lie_to_stand: code 0, but the robot showed fsm 702 (fsm_mode 0), tilt 1.80 rad for 0.3 s"), result.message


def test_lie_to_stand_waits_the_get_up_timeout_for_its_outcome() -> None:
    port = FakeRobotPort()
    _damped_lying(port)
    port.outcomes = False
    started = time.monotonic()
    result = LocoCommands(port, Gate(), outcome_timeout_s=0.1, motion_timeout_s=0.1, get_up_timeout_s=0.4,
                          tilt=lambda: 1.8).run("lie_to_stand", 0)
    assert not result.success and result.message == (
        "lie_to_stand: code 0, but the robot showed fsm 1 (fsm_mode 0), tilt 1.80 rad for 0.4 s"), result.message
    assert time.monotonic() - started >= 0.4


@pytest.mark.parametrize(("command", "fsm", "tilt", "words"), [
    ("lie_to_stand", 4, 1.8, "damp first"),
    ("lie_to_stand", 1, 0.1, "the robot is not lying"),
    ("lie_to_stand", 1, None, "attitude is unknown"),
    ("stand_up", 1, 1.8, "the robot lies on the floor (tilt 1.80 rad): damp, then lie_to_stand"),
    ("squat_to_stand", 1, 1.8, "damp, then lie_to_stand"),
])
def test_posture_verbs_the_body_does_not_allow_are_refused_with_nothing_sent(command: str, fsm: int,
                                                                              tilt: float | None, words: str) -> None:
    port = FakeRobotPort()
    port.sport = SportState(fsm_id=fsm, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)
    result = LocoCommands(port, Gate(), tilt=lambda: tilt).run(command, 0)
    assert not result.success and result.code == -1 and words in result.message, result.message
    assert port.sent == []
