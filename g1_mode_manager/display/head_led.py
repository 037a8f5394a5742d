"""The head LED shows the mode (colour + pattern from a table), and TTS may announce mode changes.

ROS-free. A worker thread of its own calls :meth:`HeadLed.tick` at a low rate (10 Hz): it *reads* the
mode and sends a colour only when it differs from the last one the robot took. It is no leave
listener and holds no lock of the mode machine while it talks to the robot, so a slow or dead voice
service can never delay an e-stop; failures are counted and logged (throttled), never raised.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import Enum

from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import VoicePort

Rgb = tuple[int, int, int]
OFF: Rgb = (0, 0, 0)
#: Pulses are quantised to this many brightness steps: a smooth look at 10 Hz with few sends.
PULSE_STEPS = 8
#: Lowest brightness of a pulse (the LED never looks off while pulsing).
PULSE_FLOOR = 0.15
#: The last colour is sent again after this long, in case someone else changed the LED (s).
REFRESH_S = 5.0


class Pattern(Enum):
    SOLID = "solid"
    PULSE = "pulse"  # brightness follows a raised cosine over the period
    FLASH = "flash"  # on for the first half of the period, off for the second


@dataclass(frozen=True)
class LedLook:
    """What the LED shows in one mode."""

    rgb: Rgb
    pattern: Pattern = Pattern.SOLID
    period_s: float = 1.0

    @classmethod
    def parse(cls, text: str) -> LedLook:
        """``"R G B [solid|pulse|flash] [period_s]"``, e.g. ``"255 0 0 flash 0.2"``; raises ValueError."""
        parts = text.replace(",", " ").split()
        if len(parts) not in (3, 4, 5):
            raise ValueError(f"LED look {text!r}: expected 'R G B [solid|pulse|flash] [period_s]'")
        try:
            rgb = tuple(int(p) for p in parts[:3])
        except ValueError:
            raise ValueError(f"LED look {text!r}: R, G, B must be integers 0..255") from None
        if any(not 0 <= c <= 255 for c in rgb):
            raise ValueError(f"LED look {text!r}: R, G, B must be integers 0..255")
        try:
            pattern = Pattern(parts[3].lower()) if len(parts) > 3 else Pattern.SOLID
        except ValueError:
            raise ValueError(f"LED look {text!r}: pattern must be solid, pulse or flash") from None
        try:
            period = float(parts[4]) if len(parts) > 4 else 1.0
        except ValueError:
            raise ValueError(f"LED look {text!r}: period must be a number of seconds") from None
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"LED look {text!r}: period must be > 0 s")
        return cls((rgb[0], rgb[1], rgb[2]), pattern, period)

    def colour_at(self, t_s: float) -> Rgb:
        """The colour this look shows at time ``t_s`` (any monotonic clock)."""
        if self.pattern is Pattern.SOLID:
            return self.rgb
        phase = (t_s % self.period_s) / self.period_s
        if self.pattern is Pattern.FLASH:
            return self.rgb if phase < 0.5 else OFF
        level = 0.5 - 0.5 * math.cos(2.0 * math.pi * phase)  # 0 -> 1 -> 0 over the period
        level = round(level * PULSE_STEPS) / PULSE_STEPS
        scale = PULSE_FLOOR + (1.0 - PULSE_FLOOR) * level
        return (round(self.rgb[0] * scale), round(self.rgb[1] * scale), round(self.rgb[2] * scale))


#: What TTS says on entering a mode.
ANNOUNCEMENTS: Mapping[Mode, str] = {
    Mode.IDLE: "idle",
    Mode.HIGH_LEVEL: "high level control",
    Mode.LOW_LEVEL: "low level control",
    Mode.EMERGENCY: "emergency stop",
}


def parse_looks(texts: Mapping[Mode, str]) -> dict[Mode, LedLook]:
    """One look per mode (the node's head_led_* parameters). Raises ValueError naming the mode."""
    looks = {}
    for mode in Mode:
        text = texts.get(mode)
        if text is None:
            raise ValueError(f"head LED of {mode.name}: no look given")
        try:
            looks[mode] = LedLook.parse(text)
        except ValueError as exc:
            raise ValueError(f"head LED of {mode.name}: {exc}") from None
    return looks


class HeadLed:
    """Drives the head LED from the mode; ``tick`` runs in the LED's own worker thread.

    ``voice`` returns the voice port, or None while the robot is not connected (nothing is sent then,
    and nothing counted as a failure). In HIGH_LEVEL, ``autonomy_look`` replaces the mode's look while
    ``autonomy_drives()``: who drives shows as well as the mode.
    """

    def __init__(self, mode: Callable[[], Mode], voice: Callable[[], VoicePort | None],
                 looks: Mapping[Mode, LedLook], events: RelayEvents, *, announce: bool = False,
                 autonomy_look: LedLook | None = None, autonomy_drives: Callable[[], bool] = lambda: False,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._mode = mode
        self._autonomy_look = autonomy_look
        self._autonomy_drives = autonomy_drives
        self._voice = voice
        self._looks = dict(looks)
        self._events = events
        self._announce = announce
        self._clock = clock
        self._sent: Rgb | None = None  # what the robot took last
        self._sent_at = -math.inf
        self._announced: Mode | None = None

    @property
    def sent(self) -> Rgb | None:
        """The colour the robot acknowledged last (None before the first)."""
        return self._sent

    def tick(self, _dt_s: float = 0.0) -> None:
        try:
            voice = self._voice()  # may create the voice client (DDS entities): can fail like a call
        except Exception as exc:
            self._events.count("head_led_failures")
            self._events.log("warn", "head_led", f"voice service unavailable: {exc}")
            return
        if voice is None:
            return
        mode = self._mode()
        now = self._clock()
        look = self._looks[mode]
        if mode is Mode.HIGH_LEVEL and self._autonomy_look is not None and self._autonomy_drives():
            look = self._autonomy_look
        colour = look.colour_at(now)
        if colour != self._sent or now - self._sent_at >= REFRESH_S:
            self._send(voice, colour, now)
        if self._announce and mode is not self._announced:
            self._say(voice, mode)

    def turn_off(self) -> None:
        """Best effort at shutdown: an LED left lit would claim a mode nobody manages any more."""
        voice = self._voice()
        if voice is not None and self._sent not in (None, OFF):
            self._send(voice, OFF, self._clock())

    def _send(self, voice: VoicePort, colour: Rgb, now: float) -> None:
        try:
            voice.set_led(*colour)
        except Exception as exc:  # never fatal: the LED is a signal, not a safety function
            self._events.count("head_led_failures")
            self._events.log("warn", "head_led", f"head LED not set: {exc}")
            return
        self._events.count("head_led_sent")
        self._sent, self._sent_at = colour, now

    def _say(self, voice: VoicePort, mode: Mode) -> None:
        self._announced = mode  # once per change, even if it fails: a retried sentence would come late
        text = ANNOUNCEMENTS.get(mode)
        if text is None:
            return
        try:
            voice.tts(text)
        except Exception as exc:
            self._events.count("tts_failures")
            self._events.log("warn", "tts", f"mode announcement not spoken: {exc}")
