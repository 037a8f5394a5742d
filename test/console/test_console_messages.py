"""The WebSocket protocol's input checks: every malformed, oversized, unknown or out-of-range message is refused
with a kind, and nothing but the known shapes gets through."""

from __future__ import annotations

import json

import pytest

from g1_mode_manager.console.messages import (
    BAD_VALUE,
    MALFORMED,
    OVERSIZED,
    UNKNOWN,
    ClearFault,
    Estop,
    HandOver,
    Loco,
    MessageRules,
    Policy,
    Recover,
    Refused,
    SetMode,
    TakeOver,
    Teleop,
)

RULES = MessageRules(["idle", "high_level", "low_level", "emergency"], {"start": None, "speed_mode": range(4)},
                     policy_verbs=("load", "shadow", "engage", "disengage", "hold", "unload"))


def teleop(**overrides) -> str:
    msg = {"type": "teleop", "visible": True, "focused": True, "vx": 0.5, "vy": 0.0, "wz": -1, "seq": 7}
    msg.update(overrides)
    return json.dumps(msg)


def test_the_known_messages_parse() -> None:
    assert RULES.parse(teleop()) == Teleop(True, True, 0.5, 0.0, -1.0, 7)
    assert RULES.parse('{"type": "set_mode", "mode": "HIGH_LEVEL"}') == SetMode("high_level")
    assert RULES.parse('{"type": "loco", "command": "start"}') == Loco("start", 0)
    assert RULES.parse('{"type": "loco", "command": "speed_mode", "value": 3}') == Loco("speed_mode", 3)
    assert RULES.parse('{"type": "estop"}') == Estop()
    assert RULES.parse('{"type": "clear_fault"}') == ClearFault()
    assert RULES.parse('{"type": "recover"}') == Recover()
    assert RULES.parse('{"type": "hand_over"}') == HandOver()
    assert RULES.parse('{"type": "take_over"}') == TakeOver()
    assert RULES.parse('{"type": "policy", "verb": "load", "policy": " loco_ppo "}') == Policy("load", "loco_ppo")
    assert RULES.parse('{"type": "policy", "verb": "load", "policy": "/home/me/my policy.yaml"}') == \
        Policy("load", "/home/me/my policy.yaml")  # a deploy config's path, spaces and all
    assert RULES.parse('{"type": "policy", "verb": "load"}') == Policy("load", "")  # the node's default
    assert RULES.parse('{"type": "policy", "verb": "ENGAGE"}') == Policy("engage", "")
    assert RULES.parse(teleop()).held and not RULES.parse(teleop(vx=0, wz=0.0)).held


@pytest.mark.parametrize(("data", "kind"), [
    (b'{"type": "estop"}', MALFORMED),
    ("", MALFORMED),
    ("not json", MALFORMED),
    ("[1, 2]", MALFORMED),
    ('{"no_type": 1}', MALFORMED),
    ('{"type": 5}', MALFORMED),
    ("[" * 5000 + "]" * 5000, OVERSIZED),
    ('{"type": "estop", "pad": "' + "x" * 2000 + '"}', OVERSIZED),
    ('{"type": "reboot"}', UNKNOWN),
    ('{"type": "estop", "extra": 1}', BAD_VALUE),
    ('{"type": "recover", "steps": ["lie_to_stand"]}', BAD_VALUE),
    ('{"type": "hand_over", "to": "nav2"}', BAD_VALUE),
    ('{"type": "take_over", "vx": 0.5}', BAD_VALUE),
    ('{"type": "hand_over_to_autonomy"}', UNKNOWN),  # the node's service name is not a command of the page
    ('{"type": "HAND_OVER"}', UNKNOWN),
    (teleop(vx=1.5), BAD_VALUE),
    (teleop(vx="0.5"), BAD_VALUE),
    (teleop(vx=True), BAD_VALUE),
    (teleop(visible=1), BAD_VALUE),
    (teleop(seq=2**40), BAD_VALUE),
    (teleop(vx=float("nan")), BAD_VALUE),  # json.dumps writes NaN, which json.loads reads back
    (teleop(wz=float("inf")), BAD_VALUE),
    ('{"type": "set_mode", "mode": "turbo"}', BAD_VALUE),
    ('{"type": "set_mode", "mode": ["idle"]}', BAD_VALUE),
    ('{"type": "loco", "command": "backflip"}', BAD_VALUE),
    ('{"type": "loco", "command": "speed_mode", "value": 4}', BAD_VALUE),
    ('{"type": "loco", "command": "speed_mode", "value": 1.5}', BAD_VALUE),
    ('{"type": "policy"}', BAD_VALUE),
    ('{"type": "policy", "verb": "resume"}', BAD_VALUE),  # the loop's own verbs are not the page's
    ('{"type": "policy", "verb": "engage", "policy": "loco_ppo"}', BAD_VALUE),  # only load takes a policy
    ('{"type": "policy", "verb": "load", "policy": 5}', BAD_VALUE),
    ('{"type": "policy", "verb": "load", "policy": "loco_ppo\\n"}', BAD_VALUE),
    ('{"type": "policy", "verb": "load", "policy": "' + "x" * 257 + '"}', BAD_VALUE),
    ('{"type": "policy", "verb": "load", "value": 1}', BAD_VALUE),
])
def test_bad_messages_are_refused_with_their_kind(data: str | bytes, kind: str) -> None:
    refused = RULES.parse(data)
    assert isinstance(refused, Refused), refused
    assert refused.kind == kind, refused.reason


def test_a_deeply_nested_message_within_the_size_limit_is_refused_not_raised() -> None:
    rules = MessageRules(["idle"], {}, max_bytes=100_000)
    refused = rules.parse("[" * 40_000 + "]" * 40_000)
    assert isinstance(refused, Refused) and refused.kind == MALFORMED
