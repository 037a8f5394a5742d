"""The high-level surface of ~/loco_command (stand height, arm tasks), checked without ROS on the fake port."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.relay.loco_command import run_loco_command


class Gate:
    """A mode machine stand-in: a mode, and whether robot_call lets a call through (an e-stop began)."""

    def __init__(self, mode: Mode = Mode.HIGH_LEVEL, open_: bool = True) -> None:
        self.mode = mode
        self.open = open_

    @contextmanager
    def robot_call(self, allowed: Callable[[Mode], bool]) -> Iterator[bool]:
        yield self.open and allowed(self.mode)


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


@pytest.mark.parametrize("command", sorted({c for c, _, _ in SURFACE}))
def test_refused_outside_high_level_while_dynamic_or_once_an_estop_began(command: str) -> None:
    for gate, sport in ((Gate(Mode.IDLE), None), (Gate(Mode.LOW_LEVEL), None), (Gate(open_=False), None),
                        (Gate(), SportState(fsm_id=500, fsm_mode=1, task_id=0, task_time=0.0, age_s=0.01))):  # fmt: skip
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
