"""The head LED shows the mode on the robot (judged from the sim's voice status), and TTS announces changes.

The node's LED worker sends colours to the robot's ``voice`` service; the sim keeps every colour change
with its CLOCK_MONOTONIC receive time, so each mode's look is checked where it lands: on the robot.
"""

from __future__ import annotations

import time

from g1_mode_manager.display.head_led import LedLook
from g1_mode_manager.node.settings import Settings
from support.mode_manager import wait_until
from support.timing import RECORD_WAIT_S

IDLE_BLUE = (0, 0, 255)
EMERGENCY_RED = (255, 0, 0)
OFF = (0, 0, 0)
#: The pulses' periods, as the node under test (its default looks) runs them.
HIGH_LEVEL_PERIOD_S = LedLook.parse(Settings().head_led_high_level).period_s
LOW_LEVEL_PERIOD_S = LedLook.parse(Settings().head_led_low_level).period_s


def _changes_since(stack, t0: float) -> list[tuple[int, int, int]]:
    return [tuple(c["rgb"]) for c in stack.sim.get()["voice"]["led_changes"] if c["t"] >= t0]


def _first_of_new_mode(stack, since: float, looks_new) -> float:
    """The robot's receive time of the first colour of the new mode. One worker sends the colours in order, so
    nothing of the old mode reaches the robot after it, however late a loaded machine delivers."""
    found: list[float] = []

    def landed() -> bool:
        found[:] = [c["t"] for c in stack.sim.get()["voice"]["led_changes"] if c["t"] >= since and looks_new(c["rgb"])]
        return bool(found)

    assert wait_until(landed, 10.0), stack.sim.get()["voice"]
    return found[0]


def _collect(stack, t0: float, seconds: float) -> set[tuple[int, int, int]]:
    time.sleep(seconds)
    return set(_changes_since(stack, t0))


def _one_period(stack, t0: float, period_s: float) -> set[tuple[int, int, int]]:
    """The colours the robot took since ``t0``, once they span a full period of the pattern that began then (a
    change received a period or more after ``t0``). The robot's record is waited for, so a node or a delivery
    slowed by a loaded machine still gives the whole period, and a quick one is not waited for beyond it."""
    def period_shown() -> bool:
        return any(c["t"] >= t0 + period_s for c in stack.sim.get()["voice"]["led_changes"])

    assert wait_until(period_shown, period_s + RECORD_WAIT_S), \
        f"the LED stopped changing on the robot: {_changes_since(stack, t0)}"
    return set(_changes_since(stack, t0))


def _green(rgb) -> bool:
    r, g, b = rgb
    return r == 0 and b == 0 and g > 0


def _amber(rgb) -> bool:
    r, g, b = rgb
    return b == 0 and r > g > 0 and abs(g / r - 120 / 255) < 0.05


def test_each_mode_shows_its_colour_and_pattern_on_the_robot(stack_factory) -> None:
    stack = stack_factory(node_params=("announce_modes:=true",), bridge_args=("--gantry",))  # LOW_LEVEL: hung
    assert stack.sim.get()["voice"]["led"] == list(OFF)  # nothing sent before the robot is connected

    since = time.monotonic()
    assert stack.set_mode("idle").success
    t0 = _first_of_new_mode(stack, since, lambda rgb: tuple(rgb) == IDLE_BLUE)
    seen = _collect(stack, t0, 1.0)
    assert seen <= {IDLE_BLUE}, seen  # solid: one colour, no flicker

    since = time.monotonic()
    assert stack.set_mode("high_level").success
    t0 = _first_of_new_mode(stack, since, _green)
    seen = _one_period(stack, t0, HIGH_LEVEL_PERIOD_S)  # HIGH_LEVEL: green pulse, period 2 s
    assert len(seen) >= 3, seen
    assert all(_green(c) for c in seen), seen

    since = time.monotonic()
    assert stack.set_mode("low_level").success
    t0 = _first_of_new_mode(stack, since, _amber)
    seen = _one_period(stack, t0, LOW_LEVEL_PERIOD_S)  # LOW_LEVEL: amber pulse, period 1 s
    assert len(seen) >= 3, seen
    assert all(_amber(c) for c in seen), seen

    since = time.monotonic()
    assert stack.estop().success
    t0 = _first_of_new_mode(stack, since, lambda rgb: tuple(rgb) == EMERGENCY_RED)
    # EMERGENCY: red flash, 200 ms period: both halves reach the robot, about 10 changes a second, not one
    assert wait_until(lambda: len(_changes_since(stack, t0)) >= 8, 5.0), _changes_since(stack, t0)
    seen = set(_changes_since(stack, t0))
    assert seen == {EMERGENCY_RED, OFF}, seen

    expected = ["idle", "high level control", "low level control", "emergency stop"]
    assert wait_until(lambda: stack.sim.get()["voice"]["tts"][-4:] == expected, 5.0), stack.sim.get()["voice"]["tts"]
