"""The head LED worker: colours and patterns per mode, sends only on change, failures counted, never raised."""

from __future__ import annotations

import pytest

from g1_mode_manager.core.modes import Mode
from g1_mode_manager.display.head_led import (
    OFF,
    REFRESH_S,
    HeadLed,
    LedLook,
    Pattern,
    parse_looks,
)
from g1_mode_manager.node.settings import Settings

#: The node's default looks (blue idle, green pulse in HIGH_LEVEL, red flash in EMERGENCY, ...).
LOOKS = Settings().led_looks()


class FakeVoice:
    def __init__(self) -> None:
        self.leds: list[tuple[int, int, int]] = []
        self.said: list[str] = []
        self.fail_led = 0
        self.fail_tts = False

    def set_led(self, r: int, g: int, b: int) -> None:
        if self.fail_led:
            self.fail_led -= 1
            raise RuntimeError("voice service timed out")
        self.leds.append((r, g, b))

    def tts(self, text: str) -> None:
        if self.fail_tts:
            raise RuntimeError("no speaker")
        self.said.append(text)


class Rig:
    def __init__(self, events, clock, *, announce: bool = False, connected: bool = True) -> None:
        self.mode = Mode.UNINITIALIZED
        self.voice = FakeVoice()
        self.connected = connected
        self.clock = clock
        self.led = HeadLed(lambda: self.mode, lambda: self.voice if self.connected else None,
                           parse_looks(LOOKS), events, announce=announce, clock=clock)

    def run(self, seconds: float, rate_hz: float = 10.0) -> None:
        for _ in range(round(seconds * rate_hz)):
            self.clock.advance(1.0 / rate_hz)
            self.led.tick()


def test_parse_accepts_the_table_format_and_rejects_nonsense() -> None:
    assert LedLook.parse("255 0 0 flash 0.2") == LedLook((255, 0, 0), Pattern.FLASH, 0.2)
    assert LedLook.parse("0,0,255") == LedLook((0, 0, 255), Pattern.SOLID, 1.0)
    for bad in ("255 0", "256 0 0", "0 0 0 blink", "0 0 0 pulse 0", "a b c", "0 0 0 pulse x"):
        with pytest.raises(ValueError):
            LedLook.parse(bad)
    with pytest.raises(ValueError, match="EMERGENCY"):
        parse_looks({**LOOKS, Mode.EMERGENCY: "red"})


def test_flash_alternates_colour_and_off_over_its_period() -> None:
    look = LedLook.parse("255 0 0 flash 0.2")
    assert look.colour_at(0.05) == (255, 0, 0) and look.colour_at(0.15) == OFF
    assert look.colour_at(10.05) == (255, 0, 0)


def test_pulse_keeps_hue_and_varies_brightness_never_off() -> None:
    look = LedLook.parse("255 120 0 pulse 1.0")
    colours = {look.colour_at(k / 20) for k in range(20)}
    assert len(colours) >= 4 and OFF not in colours
    assert all(b == 0 and r >= g for r, g, b in colours)
    assert max(colours) == (255, 120, 0)


def test_each_mode_shows_its_look_and_solid_is_sent_once(events, clock) -> None:
    rig = Rig(events, clock)
    rig.mode = Mode.IDLE
    rig.run(2.0)
    assert rig.voice.leds == [(0, 0, 255)]  # solid: one send, not 20
    rig.mode = Mode.HIGH_LEVEL
    rig.run(2.0)
    greens = rig.voice.leds[1:]
    assert len(set(greens)) >= 3 and all(r == 0 and b == 0 and g > 0 for r, g, b in greens)
    rig.mode = Mode.EMERGENCY
    before = len(rig.voice.leds)
    rig.run(1.0)
    flashes = rig.voice.leds[before:]
    assert (255, 0, 0) in flashes and OFF in flashes


def test_nothing_is_sent_or_counted_before_the_robot_is_connected(events, clock) -> None:
    rig = Rig(events, clock, connected=False)
    rig.mode = Mode.IDLE
    rig.run(1.0)
    assert rig.voice.leds == [] and events.counts() == {}


def test_failures_are_counted_logged_and_retried_never_raised(events, clock, logs) -> None:
    rig = Rig(events, clock)
    rig.mode = Mode.IDLE
    rig.voice.fail_led = 3
    rig.run(1.0)
    assert events.counts()["head_led_failures"] == 3
    assert rig.voice.leds == [(0, 0, 255)]  # retried until the robot took it
    assert any("head LED not set" in text for _level, text in logs)


def test_a_voice_port_that_cannot_be_made_is_counted_not_raised(events, clock) -> None:
    def broken():
        raise RuntimeError("no DDS participant")

    led = HeadLed(lambda: Mode.IDLE, broken, parse_looks(LOOKS), events, clock=clock)
    for _ in range(3):
        led.tick()
    assert events.counts()["head_led_failures"] == 3


def test_colour_is_refreshed_in_case_someone_else_changed_it(events, clock) -> None:
    rig = Rig(events, clock)
    rig.mode = Mode.IDLE
    rig.run(REFRESH_S + 0.5)
    assert rig.voice.leds == [(0, 0, 255)] * 2


def test_announcements_once_per_change_only_when_enabled(events, clock) -> None:
    quiet = Rig(events, clock)
    quiet.mode = Mode.HIGH_LEVEL
    quiet.run(0.5)
    assert quiet.voice.said == []
    rig = Rig(events, clock, announce=True)
    rig.mode = Mode.HIGH_LEVEL
    rig.run(0.5)
    rig.mode = Mode.EMERGENCY
    rig.run(0.5)
    assert rig.voice.said == ["high level control", "emergency stop"]
    rig.voice.fail_tts = True
    rig.mode = Mode.IDLE  # not a legal transition, but the LED only reads whatever the mode is
    rig.run(0.5)
    assert events.counts()["tts_failures"] == 1


def test_turn_off_at_shutdown_only_if_something_is_lit(events, clock) -> None:
    rig = Rig(events, clock)
    rig.led.turn_off()
    assert rig.voice.leds == []
    rig.mode = Mode.IDLE
    rig.run(0.2)
    rig.led.turn_off()
    assert rig.voice.leds[-1] == OFF


def test_fault_flashes_orange_every_half_second(events, clock) -> None:
    """The rover reference's FAULT look: orange, flashing with a 500 ms period."""
    rig = Rig(events, clock)
    rig.mode = Mode.FAULT
    rig.run(1.0, rate_hz=20.0)
    assert set(rig.voice.leds) == {(255, 80, 0), OFF}
    assert LOOKS[Mode.FAULT] == "255 80 0 flash 0.5"
