"""What a page may send over the WebSocket, checked before anything acts on it.

Every message is one JSON object with a ``type``; anything else is refused with a kind (what the page and the
counters show) and a reason. Only these exist:

* ``teleop``: ``visible``, ``focused`` (bool), ``vx``, ``vy``, ``wz`` (numbers in -1..1, fractions of the
  console's speed limits), ``seq`` (int). The page sends it every heartbeat period and at once on any change:
  it is the heartbeat, the page's visibility and the held keys or stick in one.
* ``set_mode``: ``mode`` (a mode name); ``loco``: ``command`` (a loco verb), ``value`` (int, optional);
  ``estop``; ``clear_fault``; ``recover`` (the recovery sequence: damp, lie_to_stand, balance_stand);
  ``hand_over`` (the autonomy drives) and ``take_over`` (the teleop drives again).
* ``policy``: ``verb`` (a verb of the node's ~/policy services: load, shadow, engage...), ``policy`` (load only,
  optional: a built-in name or a deploy config's path; "" or none: the node's default).
"""

from __future__ import annotations

import json
import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any, Final

#: Longest text message acted on (bytes); the WebSocket itself closes on frames of FRAME_CAP_BYTES.
MAX_MESSAGE_BYTES: Final = 1024
#: Longest policy name or deploy config path a page may ask to load (characters).
MAX_POLICY_CHARS: Final = 256
#: Refused kinds, each counted on its own.
MALFORMED, OVERSIZED, UNKNOWN, BAD_VALUE, FLOOD, BUSY = "malformed", "oversized", "unknown", "bad_value", "flood", "busy"
REFUSAL_KINDS: Final = (MALFORMED, OVERSIZED, UNKNOWN, BAD_VALUE, FLOOD, BUSY)


@dataclass(frozen=True)
class Teleop:
    visible: bool
    focused: bool
    vx: float
    vy: float
    wz: float
    seq: int

    @property
    def held(self) -> bool:
        """A key or the stick is held (any axis away from zero)."""
        return any(v != 0.0 for v in (self.vx, self.vy, self.wz))


@dataclass(frozen=True)
class SetMode:
    mode: str


@dataclass(frozen=True)
class Loco:
    command: str
    value: int = 0


@dataclass(frozen=True)
class Estop:
    pass


@dataclass(frozen=True)
class ClearFault:
    pass


@dataclass(frozen=True)
class Recover:
    pass


@dataclass(frozen=True)
class HandOver:
    pass


@dataclass(frozen=True)
class TakeOver:
    pass


@dataclass(frozen=True)
class Policy:
    verb: str
    policy: str = ""  # load only: "" is the node's default


@dataclass(frozen=True)
class Refused:
    kind: str
    reason: str


Command = Teleop | SetMode | Loco | Estop | ClearFault | Recover | HandOver | TakeOver | Policy
#: The commands that carry nothing but their type.
_BARE: Final = {"estop": Estop, "clear_fault": ClearFault, "recover": Recover, "hand_over": HandOver,
                "take_over": TakeOver}


class _BadValueError(ValueError):
    pass


def _bool(obj: Mapping[str, Any], key: str) -> bool:
    value = obj.get(key)
    if not isinstance(value, bool):
        raise _BadValueError(f"{key} must be true or false")
    return value


def _axis(obj: Mapping[str, Any], key: str) -> float:
    value = obj.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _BadValueError(f"{key} must be a finite number")
    if not -1.0 <= value <= 1.0:
        raise _BadValueError(f"{key} {value} outside -1..1")
    return float(value)


def _int(obj: Mapping[str, Any], key: str, default: int | None = None) -> int:
    value = obj.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not -(2**31) <= value < 2**31:
        raise _BadValueError(f"{key} must be a 32-bit integer")
    return value


def _name(obj: Mapping[str, Any], key: str, allowed: Collection[str]) -> str:
    value = obj.get(key)
    if not isinstance(value, str) or value.lower() not in allowed:
        raise _BadValueError(f"{key} must be one of {', '.join(sorted(allowed))}")
    return value.lower()


def _policy_name(obj: Mapping[str, Any], key: str) -> str:
    value = obj.get(key, "")
    if not isinstance(value, str) or len(value) > MAX_POLICY_CHARS or not value.isprintable():
        raise _BadValueError(f"{key} must be a printable string of at most {MAX_POLICY_CHARS} characters")
    return value.strip()


class MessageRules:
    """Parses messages against the names this console knows (modes, loco verbs and their value ranges, the
    policy verbs)."""

    def __init__(self, modes: Collection[str], verbs: Mapping[str, range | None],
                 max_bytes: int = MAX_MESSAGE_BYTES, *, policy_verbs: Collection[str] = ()) -> None:
        self._modes = frozenset(m.lower() for m in modes)
        self._verbs = dict(verbs)
        self._policy_verbs = frozenset(policy_verbs)
        self.max_bytes = max_bytes
        self._fields = {"teleop": {"type", "visible", "focused", "vx", "vy", "wz", "seq"},
                        "set_mode": {"type", "mode"}, "loco": {"type", "command", "value"},
                        "policy": {"type", "verb", "policy"}, **{kind: {"type"} for kind in _BARE}}

    def parse(self, data: str | bytes) -> Command | Refused:
        if isinstance(data, bytes):
            return Refused(MALFORMED, "binary messages are not part of the protocol")
        size = len(data.encode("utf-8", "surrogatepass"))
        if size > self.max_bytes:
            return Refused(OVERSIZED, f"{size} bytes > {self.max_bytes}")
        try:
            obj = json.loads(data)
        except (ValueError, RecursionError) as exc:
            return Refused(MALFORMED, f"not JSON: {str(exc)[:80]}")
        if not isinstance(obj, dict) or not isinstance(obj.get("type"), str):
            return Refused(MALFORMED, "expected a JSON object with a string 'type'")
        kind = obj["type"]
        fields = self._fields.get(kind)
        if fields is None:
            return Refused(UNKNOWN, f"unknown command {kind[:40]!r}")
        extra = set(obj) - fields
        if extra:
            return Refused(BAD_VALUE, f"{kind}: unknown fields {', '.join(sorted(str(k)[:20] for k in extra))}")
        try:
            return self._command(kind, obj)
        except _BadValueError as exc:
            return Refused(BAD_VALUE, f"{kind}: {exc}")

    def _command(self, kind: str, obj: Mapping[str, Any]) -> Command:
        if kind == "teleop":
            return Teleop(_bool(obj, "visible"), _bool(obj, "focused"), _axis(obj, "vx"), _axis(obj, "vy"),
                          _axis(obj, "wz"), _int(obj, "seq"))
        if kind == "set_mode":
            return SetMode(_name(obj, "mode", self._modes))
        if kind == "loco":
            command = _name(obj, "command", self._verbs)
            value = _int(obj, "value", 0)
            values = self._verbs[command]
            if values is not None and value not in values:
                raise _BadValueError(f"{command} takes {values.start}..{values.stop - 1}, not {value}")
            return Loco(command, value)
        if kind == "policy":
            verb = _name(obj, "verb", self._policy_verbs)
            if verb != "load" and "policy" in obj:
                raise _BadValueError(f"only load takes a policy, not {verb}")
            return Policy(verb, _policy_name(obj, "policy"))
        return _BARE[kind]()
