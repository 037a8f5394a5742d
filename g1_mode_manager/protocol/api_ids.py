"""RPC services of the G1: names, versions, api ids and return codes.

Names, versions and api ids as the Unitree SDK2 defines them (unitree_sdk2py's g1/loco/g1_loco_api.py,
g1/arm/g1_arm_action_api.py, g1/audio/g1_audio_api.py, comm/motion_switcher/motion_switcher_api.py);
the 3xxx return codes as its rpc/internal.py (7301 and 7302 are not in the SDK).
"""

from typing import Final

# --- sport (loco) service; it was "loco" before ai_sport 8.2 -----------------------------------
LOCO_SERVICE: Final = "sport"
LOCO_API_VERSION: Final = "1.0.0.0"

LOCO_GET_FSM_ID: Final = 7001
LOCO_GET_FSM_MODE: Final = 7002
LOCO_GET_BALANCE_MODE: Final = 7003
LOCO_GET_SWING_HEIGHT: Final = 7004
LOCO_GET_STAND_HEIGHT: Final = 7005
LOCO_GET_PHASE: Final = 7006
LOCO_SET_FSM_ID: Final = 7101  # {"data": fsm_id}
LOCO_SET_BALANCE_MODE: Final = 7102  # {"data": 0|1}
LOCO_SET_SWING_HEIGHT: Final = 7103  # {"data": metres}
LOCO_SET_STAND_HEIGHT: Final = 7104  # {"data": metres}
LOCO_SET_VELOCITY: Final = 7105  # {"velocity": [vx m/s, vy m/s, wz rad/s], "duration": s}
LOCO_SET_ARM_TASK: Final = 7106  # {"data": task}: ARM_TASK_*
LOCO_SET_SPEED_MODE: Final = 7107  # {"data": 0..3}
LOCO_SWITCH_TO_USER_CTRL: Final = 7110  # {"data": false}; joints then follow rt/user_lowcmd (newer firmware)
LOCO_SWITCH_TO_INTERNAL_CTRL: Final = 7111  # {"data": fsm.InternalCtrl}

LOCO_GET_APIS: Final = (
    LOCO_GET_FSM_ID,
    LOCO_GET_FSM_MODE,
    LOCO_GET_BALANCE_MODE,
    LOCO_GET_SWING_HEIGHT,
    LOCO_GET_STAND_HEIGHT,
    LOCO_GET_PHASE,
)
LOCO_SET_APIS: Final = (
    LOCO_SET_FSM_ID,
    LOCO_SET_BALANCE_MODE,
    LOCO_SET_SWING_HEIGHT,
    LOCO_SET_STAND_HEIGHT,
    LOCO_SET_VELOCITY,
    LOCO_SET_ARM_TASK,
    LOCO_SET_SPEED_MODE,
    LOCO_SWITCH_TO_USER_CTRL,
    LOCO_SWITCH_TO_INTERNAL_CTRL,
)

# SetArmTask's tasks (the SDK's WaveHand(turn) and ShakeHand(stage)).
ARM_TASK_WAVE: Final = 0
ARM_TASK_WAVE_AND_TURN: Final = 1
ARM_TASK_SHAKE_HAND_OUT: Final = 2  # first stage: the hand held out ...
ARM_TASK_SHAKE_HAND_BACK: Final = 3  # ... second stage: withdrawn
#: ShakeHand(stage): the task of each stage, in order.
ARM_TASK_SHAKE_HAND_STAGES: Final = (ARM_TASK_SHAKE_HAND_OUT, ARM_TASK_SHAKE_HAND_BACK)
#: SetStandHeight's HighStand / LowStand values (a uint32 all ones: "the highest"; 0: "the lowest").
STAND_HEIGHT_HIGH: Final = 0xFFFFFFFF
STAND_HEIGHT_LOW: Final = 0

#: Move's duration in s: one command lasts this long unless renewed ...
MOVE_DURATION_S: Final = 1.0
#: ... or, for a continuous move, 10 days.
MOVE_CONTINUOUS_DURATION_S: Final = 864000.0

# --- motion switcher service -----------------------------------------------------------------
MOTION_SWITCHER_SERVICE: Final = "motion_switcher"
MOTION_SWITCHER_API_VERSION: Final = "1.0.0.1"

MS_CHECK_MODE: Final = 1001  # -> {"form": str, "name": str}; name "" = released (debug mode)
MS_SELECT_MODE: Final = 1002  # {"name": "ai" | "normal" | "advanced"}
MS_RELEASE_MODE: Final = 1003
MS_SET_SILENT: Final = 1004  # {"silent": bool}
MS_GET_SILENT: Final = 1005  # -> {"silent": bool}

#: The high-level service this package selects.
HIGH_LEVEL_SERVICE_NAME: Final = "ai"

# --- arm action service (the robot's canned upper-body actions) -----------------------------------
ARM_SERVICE: Final = "arm"
ARM_API_VERSION: Final = "1.0.0.14"
ARM_EXECUTE_ACTION: Final = 7106  # {"data": action_id} (Python SDK) or {"action_id": action_id} (C++ SDK)
ARM_GET_ACTION_LIST: Final = 7107
ARM_APIS: Final = (ARM_EXECUTE_ACTION, ARM_GET_ACTION_LIST)
ARM_ACTION_RELEASE: Final = 99  # "release arm": ends any action
#: Actions taught with Unitree's app, by name (C++ SDK only).
ARM_EXECUTE_CUSTOM_ACTION: Final = 7108  # {"action_name": str}
ARM_STOP_CUSTOM_ACTION: Final = 7113
ARM_ERR_INVALID_ACTION_ID: Final = 7402  # "Invalid action id." (C++ SDK g1_arm_action_error.hpp)

# --- voice service (speaker, microphone, head RGB LED) -------------------------------------------
VOICE_SERVICE: Final = "voice"
VOICE_API_VERSION: Final = "1.0.0.0"

VOICE_TTS: Final = 1001  # {"index": int, "text": str, "speaker_id": int}
VOICE_GET_VOLUME: Final = 1005  # -> {"volume": 0..100}
VOICE_SET_VOLUME: Final = 1006  # {"volume": 0..100}
VOICE_SET_LED: Final = 1010  # {"R": 0..255, "G": 0..255, "B": 0..255}: the head RGB LED
VOICE_APIS: Final = (VOICE_TTS, VOICE_GET_VOLUME, VOICE_SET_VOLUME, VOICE_SET_LED)
#: Playing a PCM stream sent in chunks (the request's binary part: 16 kHz mono 16-bit), and stopping it.
VOICE_START_PLAY: Final = 1003  # {"app_name": str, "stream_id": str} + PCM bytes
VOICE_STOP_PLAY: Final = 1004  # {"app_name": str}

# --- return codes ------------------------------------------------------------------------------
OK: Final = 0
ERR_UNKNOWN: Final = 3001
ERR_CLIENT_SEND: Final = 3102
ERR_CLIENT_API_NOT_REG: Final = 3103
ERR_CLIENT_API_TIMEOUT: Final = 3104
ERR_CLIENT_API_NOT_MATCH: Final = 3105
ERR_CLIENT_API_DATA: Final = 3106
ERR_SERVER_INTERNAL: Final = 3202
ERR_SERVER_API_NOT_IMPL: Final = 3203
ERR_SERVER_API_PARAMETER: Final = 3204
ERR_INVALID_FSM_ID: Final = 7302
#: Returned by the sim (and, we assume, the robot) for a request the controller refuses in its state.
ERR_REFUSED_IN_STATE: Final = 7301

CODE_NAMES: Final = {
    OK: "ok",
    ERR_UNKNOWN: "unknown error",
    ERR_CLIENT_SEND: "send error (no server matched)",
    ERR_CLIENT_API_NOT_REG: "api not registered in client",
    ERR_CLIENT_API_TIMEOUT: "timeout",
    ERR_CLIENT_API_NOT_MATCH: "reply does not match the request",
    ERR_CLIENT_API_DATA: "reply data malformed",
    ERR_SERVER_INTERNAL: "server internal error",
    ERR_SERVER_API_NOT_IMPL: "api not implemented (service inactive?)",
    ERR_SERVER_API_PARAMETER: "bad parameter",
    ERR_REFUSED_IN_STATE: "refused in the controller's current state",
    ERR_INVALID_FSM_ID: "invalid fsm id",
}


def describe_code(code: int) -> str:
    """A human-readable name for an RPC return code, e.g. ``3104 (timeout)``."""
    return f"{code} ({CODE_NAMES.get(code, 'unknown code')})"
