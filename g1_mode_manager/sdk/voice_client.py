"""The G1's ``voice`` service: head RGB LED, text to speech and volume, raising RobotError on every failure.

The node uses it only for signalling (the LED shows the mode, TTS may announce changes); nothing
safety-related goes through it, so it has its own client and short timeouts of its own.
"""

from __future__ import annotations

import json

from g1_mode_manager.core.port import RobotError
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.sdk.rpc_client import RpcClient, parse_number

#: Speaker id of the G1's default voice (Unitree's examples use 0).
DEFAULT_SPEAKER_ID = 0


def _channel(name: str, value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 255:
        raise ValueError(f"SetLed: {name} must be an integer 0..255, got {value!r}")
    return value


class VoiceClient(RpcClient):
    """Voice calls of the G1. Each takes an optional ``timeout_s`` (default: the client's)."""

    def __init__(self, timeout_s: float = 0.5) -> None:
        super().__init__(api.VOICE_SERVICE, api.VOICE_API_VERSION, api.VOICE_APIS, timeout_s)
        self._tts_index = 0

    def set_led(self, r: int, g: int, b: int, *, timeout_s: float | None = None) -> None:
        """Head LED colour, 0..255 per channel (0, 0, 0 = off)."""
        parameter = {"R": _channel("R", r), "G": _channel("G", g), "B": _channel("B", b)}
        self.call("SetLed", api.VOICE_SET_LED, parameter, timeout_s=timeout_s)

    def tts(self, text: str, *, speaker_id: int = DEFAULT_SPEAKER_ID, timeout_s: float | None = None) -> None:
        """Say ``text``; each utterance gets a new index, as the robot expects."""
        if not isinstance(text, str) or not text.strip():
            raise ValueError("TtsMaker: text must be a non-empty string")
        self._tts_index += 1
        parameter = {"index": self._tts_index, "text": text, "speaker_id": int(speaker_id)}
        self.call("TtsMaker", api.VOICE_TTS, parameter, timeout_s=timeout_s)

    def get_volume(self, *, timeout_s: float | None = None) -> int:
        data = self.call("GetVolume", api.VOICE_GET_VOLUME, timeout_s=timeout_s)
        try:
            value = json.loads(data)
        except (TypeError, ValueError):
            raise RobotError("GetVolume", api.ERR_CLIENT_API_DATA, f"reply is not JSON: {data!r}") from None
        if isinstance(value, dict) and "volume" in value:
            data = json.dumps({"data": value["volume"]})
        return parse_number("GetVolume", data, int)

    def set_volume(self, volume: int, *, timeout_s: float | None = None) -> None:
        if isinstance(volume, bool) or not isinstance(volume, int) or not 0 <= volume <= 100:
            raise ValueError(f"SetVolume: volume must be an integer 0..100, got {volume!r}")
        self.call("SetVolume", api.VOICE_SET_VOLUME, {"volume": volume}, timeout_s=timeout_s)
