"""The head LED shows the mode on the robot (judged from the sim's voice status), and TTS announces changes.

The node's LED worker sends colours to the robot's ``voice`` service; the sim keeps every colour change
with its CLOCK_MONOTONIC receive time, so each mode's look is checked where it lands: on the robot.
"""

from __future__ import annotations

import time

from support.mode_manager import wait_until

IDLE_BLUE = (0, 0, 255)
EMERGENCY_RED = (255, 0, 0)
OFF = (0, 0, 0)


def _changes_since(stack, t0: float) -> list[tuple[int, int, int]]:
    return [tuple(c["rgb"]) for c in stack.sim.get()["voice"]["led_changes"] if c["t"] >= t0]


def _after_change() -> float:
    """A moment after the mode changed by which the LED worker (10 Hz) has seen the new mode."""
    time.sleep(0.2)
    return time.monotonic()


def _collect(stack, t0: float, seconds: float) -> set[tuple[int, int, int]]:
    time.sleep(seconds)
    return set(_changes_since(stack, t0))


def test_each_mode_shows_its_colour_and_pattern_on_the_robot(stack_factory) -> None:
    stack = stack_factory(node_params=("announce_modes:=true",), bridge_args=("--gantry",))  # LOW_LEVEL: hung
    assert stack.sim.get()["voice"]["led"] == list(OFF)  # nothing sent before the robot is connected

    assert stack.set_mode("idle").success
    t0 = _after_change()
    assert wait_until(lambda: tuple(stack.sim.get()["voice"]["led"]) == IDLE_BLUE, 5.0), stack.sim.get()["voice"]
    seen = _collect(stack, t0, 1.0)
    assert seen <= {IDLE_BLUE}, seen  # solid: one colour, no flicker

    assert stack.set_mode("high_level").success
    t0 = _after_change()
    seen = _collect(stack, t0, 2.5)  # HIGH_LEVEL: green pulse, period 2 s
    assert len(seen) >= 3, seen
    assert all(r == 0 and b == 0 and g > 0 for r, g, b in seen), seen

    assert stack.set_mode("low_level").success
    t0 = _after_change()
    seen = _collect(stack, t0, 1.5)  # LOW_LEVEL: amber pulse, period 1 s
    assert len(seen) >= 3, seen
    assert all(b == 0 and r > g > 0 and abs(g / r - 120 / 255) < 0.05 for r, g, b in seen), seen

    assert stack.estop().success
    t0 = _after_change()
    seen = _collect(stack, t0, 1.5)  # EMERGENCY: red flash, 200 ms period: both halves reach the robot
    assert seen == {EMERGENCY_RED, OFF}, seen
    flips = _changes_since(stack, t0)
    assert len(flips) >= 8, flips  # ~10 changes a second, not one

    said = stack.sim.get()["voice"]["tts"]
    assert said[-4:] == ["idle", "high level control", "low level control", "emergency stop"], said
