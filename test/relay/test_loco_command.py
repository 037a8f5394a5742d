"""~/loco_command without ROS on the fake port: what each verb sends, when it is refused, and that it is answered
on the outcome the robot shows, not on the return code: for a posture verb, the posture its body reaches, and
nothing sent when that outcome holds already."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.core.posture import NO_READING, Posture, PostureReading
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, FsmId
from g1_mode_manager.relay.loco_command import LocoCommands, LocoResult

P = Posture
#: The tilt each posture is shown at (the body watch reads it with the posture).
_TILT = {P.LYING_BACK: 1.8, P.LYING_FRONT: 1.8, P.UNKNOWN: 0.3}


class Gate:
    """A mode machine stand-in: a mode, and whether robot_call lets a call through (an e-stop began)."""

    def __init__(self, mode: Mode = Mode.HIGH_LEVEL, open_: bool = True) -> None:
        self.mode = mode
        self.open = open_

    @contextmanager
    def robot_call(self, allowed: Callable[[Mode], bool]) -> Iterator[bool]:
        yield self.open and allowed(self.mode)


class BodyPort(FakeRobotPort):
    """The fake port with a body: its posture follows the fsm as the robot's does (706 squats a standing robot
    and stands any other up; damping leaves it where it is), unless ``body_moves`` is False (a controller that
    shows the fsm while the body stays). ``reading`` is what the body watch would read; ``readings``, if set,
    is read one at a time instead."""

    def __init__(self, posture: Posture = P.STANDING, fsm_id: int = FsmId.STAND_UP) -> None:
        super().__init__()
        self.posture = posture
        self.sport = SportState(fsm_id=fsm_id, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)
        self.body_moves = True
        self.sampled = True  # False: no state sample (the body watch reads nothing)
        self.readings: Iterator[PostureReading] | None = None

    def reading(self) -> PostureReading:
        if self.readings is not None:
            return next(self.readings)
        return PostureReading(self.posture, _TILT.get(self.posture, 0.05)) if self.sampled else NO_READING

    def set_fsm_id(self, fsm_id: int) -> None:
        before = self.sport.fsm_id if self.sport is not None else None
        super().set_fsm_id(fsm_id)
        if not (self.outcomes and self.body_moves) or fsm_id in self.ignored_fsm_ids:
            return
        if fsm_id == FsmId.SQUAT_TO_STAND:
            squats = before in STANDING_FSM_IDS and self.posture is P.STANDING
            self.posture = P.SQUATTING if squats else P.STANDING
        elif fsm_id in STANDING_FSM_IDS:
            self.posture = P.STANDING
        elif fsm_id in (FsmId.SQUAT, FsmId.SIT):
            self.posture = P.SQUATTING if fsm_id == FsmId.SQUAT else P.SITTING


def _commands(port: BodyPort, gate: Gate, timeout_s: float = 0.3, **kwargs) -> LocoCommands:
    return LocoCommands(port, gate, outcome_timeout_s=timeout_s, motion_timeout_s=timeout_s, posture=port.reading,
                        **kwargs)


def run_loco_command(port: BodyPort, gate: Gate, command: str, value: int, *, timeout_s: float = 0.3) -> LocoResult:
    return _commands(port, gate, timeout_s).run(command, value)


def _sent(port: FakeRobotPort) -> list[tuple]:
    return [(s.name, s.args) for s in port.sent]


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


#: Where a posture verb starts from when it is to be sent (elsewhere its outcome would hold already): fsm and
#: posture. The others start standing in lock stand (fsm 4).
START = {"stand_up": (FsmId.START, P.STANDING), "squat_to_stand": (FsmId.DAMP, P.SQUATTING)}


def _port_for(command: str) -> BodyPort:
    fsm, posture = START.get(command, (FsmId.STAND_UP, P.STANDING))
    return BodyPort(posture, fsm)


@pytest.mark.parametrize(("command", "value", "sent"), SURFACE + POSTURE)
def test_each_command_sends_its_call_in_high_level_while_static(command: str, value: int, sent: tuple) -> None:
    port = _port_for(command)
    result = run_loco_command(port, Gate(), command, value)
    assert result.success and result.code == 0, result.message
    assert _sent(port) == [sent]
    if command == "speed_mode":  # nothing on the robot to read it back from: said, and no outcome time
        assert "not verified" in result.message and result.outcome_s == -1.0
    else:
        assert "done, the robot shows" in result.message and 0.0 < result.outcome_s < 0.3, result


@pytest.mark.parametrize(("command", "value", "sent"), [c for c in SURFACE + POSTURE if c[0] != "speed_mode"])
def test_each_command_fails_with_code_0_when_the_robot_does_not_show_its_outcome(command: str, value: int,
                                                                                 sent: tuple) -> None:
    port = _port_for(command)
    port.balance_mode = 1 - value if command == "continuous_gait" else 1  # so that a change would show
    port.outcomes = False
    started = time.monotonic()
    result = run_loco_command(port, Gate(), command, value, timeout_s=0.2)
    waited = time.monotonic() - started
    assert not result.success and result.code == 0 and result.outcome_s == -1.0, result
    # a posture verb's robot that kept its fsm and posture is said to have not moved; the others show what they showed
    said = ("the robot accepted it and did not move" if command in ("squat", "sit", "stand_up", "squat_to_stand",
                                                                     "stand_to_squat") else "but the robot showed")
    assert said in result.message and "for 0.2 s" in result.message, result.message
    assert waited >= 0.2
    assert _sent(port) == [sent]


def test_start_ignored_by_the_firmware_answers_false_with_the_fsm_it_saw() -> None:
    port = BodyPort()
    port.ignored_fsm_ids = {500}
    result = run_loco_command(port, Gate(), "start", 0, timeout_s=0.2)
    assert not result.success and result.code == 0
    assert result.message == "start: code 0, but the robot showed fsm 4 (fsm_mode 0) for 0.2 s"


def test_a_state_from_before_the_send_does_not_count_as_the_outcome() -> None:
    port = BodyPort()
    port.sport = SportState(fsm_id=1, fsm_mode=0, task_id=0, task_time=0.0, age_s=5.0)  # damped, but stale
    port.outcomes = False
    result = run_loco_command(port, Gate(Mode.IDLE), "damp", 0, timeout_s=0.2)
    assert not result.success and "nothing yet" in result.message, result.message


def test_a_task_that_began_before_the_send_is_not_its_outcome() -> None:
    port = BodyPort()
    port.sport = SportState(fsm_id=500, fsm_mode=0, task_id=0, task_time=1.5, age_s=0.01)  # a wave half played
    port.outcomes = False
    result = run_loco_command(port, Gate(), "wave_hand", 0, timeout_s=0.2)
    assert not result.success and "task 0 at 1.50 s" in result.message, result.message


def test_a_stand_height_already_at_a_verified_extreme_counts_without_moving() -> None:
    port = BodyPort()
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
    port = BodyPort()
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
        port = BodyPort()
        if sport is not None:
            port.sport = sport
        result = run_loco_command(port, gate, command, 0)
        assert not result.success and result.code == -1, (gate.mode, result.message)
        assert port.sent == []


@pytest.mark.parametrize(("command", "value", "needle"), [
    ("continuous_gait", 2, "value from 0 to 1"), ("speed_mode", 4, "value from 0 to 3"), ("fly", 0, "unknown command"),
])
def test_values_out_of_range_and_unknown_verbs_are_refused_unsent(command: str, value: int, needle: str) -> None:
    port = BodyPort()
    result = run_loco_command(port, Gate(), command, value)
    assert not result.success and needle in result.message and port.sent == []


def test_shake_hand_takes_only_its_two_stages() -> None:
    port = BodyPort()
    result = run_loco_command(port, Gate(), "shake_hand", 2)
    assert not result.success and "value from 0 to 1" in result.message and port.sent == []


def test_lie_to_stand_sends_702_damped_and_lying_and_is_answered_on_702_static_with_the_robot_up() -> None:
    port = BodyPort(P.LYING_BACK, FsmId.DAMP)
    result = _commands(port, Gate(), 0.2, get_up_timeout_s=0.3).run("lie_to_stand", 0)
    assert result.success and _sent(port) == [("set_fsm_id", (702,))], result.message
    assert "the robot shows fsm 702 (fsm_mode 0), standing, tilt 0.05 rad" in result.message


def test_702_static_with_the_robot_still_on_the_floor_is_not_a_get_up() -> None:
    port = BodyPort(P.LYING_BACK, FsmId.DAMP)
    port.body_moves = False
    result = _commands(port, Gate(), 0.1, get_up_timeout_s=0.3).run("lie_to_stand", 0)
    assert not result.success and result.message == ("lie_to_stand: code 0, but the robot showed fsm 702 (fsm_mode 0), "
                                                     "lying_back, tilt 1.80 rad for 0.3 s"), result.message


def test_lie_to_stand_waits_the_get_up_timeout_for_its_outcome() -> None:
    port = BodyPort(P.LYING_BACK, FsmId.DAMP)
    port.outcomes = False
    started = time.monotonic()
    result = _commands(port, Gate(), 0.1, get_up_timeout_s=0.4).run("lie_to_stand", 0)
    assert not result.success and result.message == (
        "lie_to_stand: code 0, the robot accepted it and did not move: it showed fsm 1 (fsm_mode 0), lying_back, "
        "tilt 1.80 rad for 0.4 s"), result.message
    assert time.monotonic() - started >= 0.4


@pytest.mark.parametrize(("command", "fsm", "posture", "words"), [
    ("lie_to_stand", 4, P.LYING_BACK, "damp first"),
    ("lie_to_stand", 1, P.UNKNOWN, "the robot is not lying"),
    ("lie_to_stand", 1, P.SQUATTING, "the robot is not lying"),
    ("stand_up", 1, P.LYING_BACK, "the robot lies on the floor (lying_back, tilt 1.80 rad): damp, then lie_to_stand"),
    ("squat_to_stand", 1, P.LYING_FRONT, "damp, then lie_to_stand"),
    # the vendor's note: from the squat 706 left (no damp since), up again is damp, then 706
    ("squat_to_stand", 706, P.SQUATTING, "damp first, then squat_to_stand"),
    ("stand_to_squat", 3, P.SITTING, "stand_to_squat squats a standing robot down"),
])
def test_posture_verbs_the_body_does_not_allow_are_refused_with_nothing_sent(command: str, fsm: int, posture: Posture,
                                                                              words: str) -> None:
    port = BodyPort(posture, fsm)
    result = _commands(port, Gate()).run(command, 0)
    assert not result.success and result.code == -1 and words in result.message, result.message
    assert port.sent == []


@pytest.mark.parametrize("command", ["stand_up", "squat", "sit", "squat_to_stand", "stand_to_squat", "lie_to_stand"])
def test_a_posture_verb_is_refused_unsent_while_no_state_sample_shows_the_body(command: str) -> None:
    port = BodyPort(P.LYING_BACK, FsmId.DAMP) if command == "lie_to_stand" else _port_for(command)
    port.sampled = False
    result = _commands(port, Gate()).run(command, 0)
    assert not result.success and result.code == -1 and "no state sample" in result.message, result.message
    assert port.sent == []


def test_squat_to_stand_from_the_squat_706_left_is_refused_and_allowed_after_a_damp() -> None:
    """stand -> stand_to_squat -> squat_to_stand: refused, nothing sent; damp -> squat_to_stand: up (the vendor's
    flow, and the power-on one from a damped squat)."""
    port = BodyPort()
    commands = _commands(port, Gate())
    down = commands.run("stand_to_squat", 0)
    assert down.success and "fsm 706 (fsm_mode 0), squatting" in down.message, down.message
    refused = commands.run("squat_to_stand", 0)
    assert not refused.success and refused.code == -1, refused.message
    assert refused.message.endswith("the vendor's way up from there: damp first, then squat_to_stand"), refused.message
    assert _sent(port) == [("set_fsm_id", (706,))]
    assert commands.run("damp", 0).success
    up = commands.run("squat_to_stand", 0)
    assert up.success and "fsm 706 (fsm_mode 0), standing" in up.message, up.message
    assert _sent(port) == [("set_fsm_id", (706,)), ("set_fsm_id", (1,)), ("set_fsm_id", (706,))]


@pytest.mark.parametrize(("command", "fsm", "posture"), [
    ("squat_to_stand", FsmId.STAND_UP, P.STANDING),  # 706 would squat it down
    ("squat_to_stand", FsmId.SQUAT_TO_STAND, P.STANDING),
    ("stand_to_squat", FsmId.SQUAT_TO_STAND, P.SQUATTING),  # 706 would stand it up
    ("stand_to_squat", FsmId.DAMP, P.SQUATTING),
    ("lie_to_stand", FsmId.LIE_TO_STAND, P.STANDING),
    ("stand_up", FsmId.STAND_UP, P.STANDING),
    ("squat", FsmId.SQUAT, P.SQUATTING),
    ("sit", FsmId.SIT, P.SITTING),
])
def test_an_outcome_that_holds_already_is_answered_so_with_nothing_sent(command: str, fsm: int,
                                                                         posture: Posture) -> None:
    port = BodyPort(posture, fsm)
    result = _commands(port, Gate()).run(command, 0)
    assert result.success and result.code == -1 and result.outcome_s == -1.0, result
    assert result.message == f"{command}: already {posture.value}, tilt 0.05 rad (fsm {fsm}): nothing sent"
    assert port.sent == []


def test_an_fsm_shown_without_the_posture_is_not_the_outcome() -> None:
    """706 static is either end of its motion: a robot that shows it with its body still squatting has not stood
    up (today's robot answered that with success)."""
    port = BodyPort(P.SQUATTING, FsmId.DAMP)
    port.body_moves = False
    result = _commands(port, Gate(), 0.2).run("squat_to_stand", 0)
    assert not result.success and result.code == 0, result.message
    assert result.message == ("squat_to_stand: code 0, but the robot showed fsm 706 (fsm_mode 0), squatting, "
                              "tilt 0.05 rad for 0.2 s"), result.message


def test_the_answer_waits_for_the_posture_after_the_fsm_settled() -> None:
    port = BodyPort(P.STANDING, FsmId.STAND_UP)
    on_the_way = PostureReading(P.UNKNOWN, 0.03)
    # before the send: standing; then the fsm settles while the body is still on its way, then squats
    port.readings = iter([PostureReading(P.STANDING, 0.01), PostureReading(P.STANDING, 0.01)] + [on_the_way] * 20
                         + [PostureReading(P.SQUATTING, 0.04)] * 100)
    result = _commands(port, Gate(), 1.0).run("stand_to_squat", 0)
    assert result.success and "squatting, tilt 0.04 rad" in result.message, result.message


def test_a_robot_that_answers_0_and_does_not_move_is_told_apart_within_the_timeout() -> None:
    port = BodyPort()
    port.ignored_fsm_ids = {int(FsmId.SQUAT_TO_STAND)}  # answers 0, nothing happens
    started = time.monotonic()
    result = _commands(port, Gate(), 0.3).run("stand_to_squat", 0)
    took = time.monotonic() - started
    assert not result.success and result.code == 0, result.message
    assert result.message == ("stand_to_squat: code 0, the robot accepted it and did not move: it showed fsm 4 "
                              "(fsm_mode 0), standing, tilt 0.05 rad for 0.3 s"), result.message
    assert 0.3 <= took < 0.3 + 0.5
    port = BodyPort()
    port.body_moves = False  # the fsm moves, the body does not: that is not "did not move", and not the outcome
    result = _commands(port, Gate(), 0.2).run("stand_to_squat", 0)
    assert not result.success and "but the robot showed fsm 706 (fsm_mode 0), standing" in result.message, result.message
