"""The sim's voice service handlers: LED colour kept with its changes, TTS kept, volume, bad parameters 3204."""

from __future__ import annotations

import json

from g1_mode_manager.protocol import api_ids as api
from g1_sim.bridge.voice import BOOT_VOLUME, VoiceState, voice_handlers


def test_led_tts_and_volume_are_kept_and_reported() -> None:
    state = VoiceState()
    h = voice_handlers(state)
    assert h[api.VOICE_SET_LED](json.dumps({"R": 255, "G": 0, "B": 0})) == (api.OK, "")
    assert h[api.VOICE_SET_LED](json.dumps({"R": 255, "G": 0, "B": 0})) == (api.OK, "")
    assert h[api.VOICE_SET_LED](json.dumps({"R": 0, "G": 0, "B": 0})) == (api.OK, "")
    assert h[api.VOICE_TTS](json.dumps({"index": 1, "text": "emergency stop", "speaker_id": 0})) == (api.OK, "")
    assert json.loads(h[api.VOICE_GET_VOLUME]("{}")[1]) == {"volume": BOOT_VOLUME}
    assert h[api.VOICE_SET_VOLUME](json.dumps({"volume": 30})) == (api.OK, "")
    status = state.status()
    assert status["led"] == [0, 0, 0] and status["led_requests"] == 3
    assert [c["rgb"] for c in status["led_changes"]] == [[255, 0, 0], [0, 0, 0]]  # changes only
    assert status["tts"] == ["emergency stop"] and status["volume"] == 30


def test_bad_parameters_answer_3204_and_change_nothing() -> None:
    state = VoiceState()
    h = voice_handlers(state)
    for api_id, parameter in ((api.VOICE_SET_LED, {"R": 256, "G": 0, "B": 0}), (api.VOICE_SET_LED, {"R": 1}),
                              (api.VOICE_SET_VOLUME, {"volume": 101}), (api.VOICE_TTS, {"text": 5})):
        assert h[api_id](json.dumps(parameter))[0] == api.ERR_SERVER_API_PARAMETER
    assert state.status()["led"] == [0, 0, 0] and state.status()["tts"] == [] and state.volume == BOOT_VOLUME


def test_audio_streams_are_taken_and_stopped_as_a_robot_with_a_speaker_does() -> None:
    state = VoiceState()
    h = voice_handlers(state)
    chunk = json.dumps({"app_name": "example", "stream_id": "1700000000000"})
    assert h[api.VOICE_START_PLAY](chunk) == (api.OK, "")  # the PCM chunk rides in the request's binary part
    assert h[api.VOICE_START_PLAY](chunk) == (api.OK, "")
    assert h[api.VOICE_STOP_PLAY](json.dumps({"app_name": "example"})) == (api.OK, "")
    assert h[api.VOICE_STOP_PLAY](json.dumps({"app_name": "example"})) == (api.OK, "")  # nothing playing: 0 too
    assert state.status()["play"] == {"chunks": 2, "stops": 2, "stream": None}
    assert h[api.VOICE_START_PLAY](json.dumps({"app_name": "example"}))[0] == api.ERR_SERVER_API_PARAMETER
