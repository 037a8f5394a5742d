"""The G1's ``voice`` service in the sim: the head LED colour is kept, TTS is logged, volume get/set, audio
streams taken and dropped.

The robot shows the LED, speaks and plays; the sim remembers what it was told, so tests can judge the LED
from the robot's side (status ``voice``: current colour, recent colour changes, recent sentences, streams).
PlayStream (1003) answers 0 and counts the chunk (the sim has no speaker; the PCM bytes, the request's binary
part, never reach a JSON handler); PlayStop (1004) answers 0, as with nothing playing. ASR (1002) is not
served (3203): its results come on rt/audio_msg, which the sim never writes, like a robot hearing nothing.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from g1_mode_manager.protocol import api_ids as api
from g1_sim.bridge.rpc_services import BadParameterError, Reply, _guarded, _integer

log = logging.getLogger("g1_sim.voice")
#: The robot boots with its volume here (0..100); a guess, the real value is not documented.
BOOT_VOLUME = 80


class VoiceState:
    """LED colour, its recent changes (with CLOCK_MONOTONIC times), recent TTS texts, volume; thread-safe."""

    HISTORY = 64
    TTS_KEPT = 16

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.led = [0, 0, 0]
        self._led_changes: deque[dict[str, Any]] = deque(maxlen=self.HISTORY)
        self._tts: deque[str] = deque(maxlen=self.TTS_KEPT)
        self.volume = BOOT_VOLUME
        self.led_requests = 0
        self._play_chunks = 0
        self._play_stops = 0
        self._stream: dict[str, str] | None = None

    def set_led(self, rgb: list[int]) -> None:
        with self._lock:
            self.led_requests += 1
            if rgb != self.led:
                self._led_changes.append({"t": time.monotonic(), "rgb": list(rgb)})
            self.led = list(rgb)

    def say(self, text: str) -> None:
        log.info("TTS: %s", text)
        with self._lock:
            self._tts.append(text)

    def play(self, app_name: str, stream_id: str) -> None:
        with self._lock:
            self._play_chunks += 1
            self._stream = {"app_name": app_name, "stream_id": stream_id}

    def stop_play(self) -> None:
        with self._lock:
            self._play_stops += 1
            self._stream = None

    def set_volume(self, volume: int) -> None:
        with self._lock:
            self.volume = volume

    def status(self) -> dict[str, Any]:
        with self._lock:
            return {"led": list(self.led), "led_changes": [dict(c) for c in self._led_changes],
                    "led_requests": self.led_requests, "tts": list(self._tts), "volume": self.volume,
                    "play": {"chunks": self._play_chunks, "stops": self._play_stops, "stream": self._stream}}


def voice_handlers(state: VoiceState) -> dict[int, Callable[[str], Reply]]:
    """Handlers of the voice service by api id (ASR is not served: 3203)."""

    def set_led(p: dict[str, Any]) -> Reply:
        rgb = [_integer(p, key) for key in ("R", "G", "B")]
        if any(not 0 <= c <= 255 for c in rgb):
            raise BadParameterError(f"R, G, B must be 0..255, got {rgb}")
        state.set_led(rgb)
        return (api.OK, "")

    def tts(p: dict[str, Any]) -> Reply:
        text = p.get("text")
        if not isinstance(text, str):
            raise BadParameterError(f"'text' must be a string, got {text!r}")
        state.say(text)
        return (api.OK, "")

    def set_volume(p: dict[str, Any]) -> Reply:
        volume = _integer(p, "volume")
        if not 0 <= volume <= 100:
            raise BadParameterError(f"'volume' must be 0..100, got {volume}")
        state.set_volume(volume)
        return (api.OK, "")

    def _text(p: dict[str, Any], key: str) -> str:
        value = p.get(key)
        if not isinstance(value, str):
            raise BadParameterError(f"{key!r} must be a string, got {value!r}")
        return value

    def start_play(p: dict[str, Any]) -> Reply:
        state.play(_text(p, "app_name"), _text(p, "stream_id"))
        return (api.OK, "")

    def stop_play(p: dict[str, Any]) -> Reply:
        _text(p, "app_name")
        state.stop_play()
        return (api.OK, "")

    table: dict[int, Callable[[dict[str, Any]], Reply]] = {
        api.VOICE_SET_LED: set_led,
        api.VOICE_START_PLAY: start_play,
        api.VOICE_STOP_PLAY: stop_play,
        api.VOICE_TTS: tts,
        api.VOICE_GET_VOLUME: lambda p: (api.OK, json.dumps({"volume": state.volume})),
        api.VOICE_SET_VOLUME: set_volume,
    }
    return {api_id: _guarded(h) for api_id, h in table.items()}
