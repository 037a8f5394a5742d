"""Health of the robot link: are the robot's state streams fresh enough to forward commands?"""

from __future__ import annotations

from dataclasses import dataclass

from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.relay.gate import ModeGate


@dataclass(frozen=True)
class LinkReport:
    ok: bool
    connected: bool
    lowstate_age_s: float | None
    sportstate_age_s: float | None
    reason: str


class LinkHealth:
    """rt/lowstate must be fresh in every connected mode; rt/sportmodestate too in HIGH_LEVEL.

    In HIGH_LEVEL the node may not receive rt/lowstate at all (LowStateDemand: nothing needs it): then
    rt/sportmodestate, the high-level service's own stream, is the link's evidence on its own.
    Before the first transition nothing is connected: not an error, but nothing may be forwarded.
    """

    def __init__(self, port: RobotPort, gate: ModeGate, timeout_s: float) -> None:
        self._port = port
        self._gate = gate
        self._timeout_s = timeout_s

    def report(self) -> LinkReport:
        mode = self._gate.mode
        if mode is Mode.UNINITIALIZED:
            return LinkReport(False, False, None, None, "not connected yet (UNINITIALIZED)")
        low = self._port.lowstate_age_s()
        sport_state = self._port.sport_state()
        sport = None if sport_state is None else sport_state.age_s
        lowstate_judged = mode is not Mode.HIGH_LEVEL or self._port.lowstate_receiving()
        if not lowstate_judged:
            low = None
        elif low is None or low > self._timeout_s:
            text = "never received" if low is None else f"{low:.2f} s old"
            return LinkReport(False, True, low, sport, f"rt/lowstate {text}")
        if mode is Mode.HIGH_LEVEL and (sport is None or sport > self._timeout_s):
            text = "never received" if sport is None else f"{sport:.2f} s old"
            return LinkReport(False, True, low, sport, f"rt/sportmodestate {text}")
        return LinkReport(True, True, low, sport, "ok")

    def link_ok(self, mode: Mode) -> bool:
        """``report().ok`` without the report, for ``mode``: the one the forward gate judged, handed on so that
        a frame's mode is read once. Asked under the gate before every forwarded frame (500 Hz in LOW_LEVEL),
        it reads only the stream that decides (rt/sportmodestate only in HIGH_LEVEL)."""
        if mode is Mode.UNINITIALIZED:
            return False
        if mode is not Mode.HIGH_LEVEL or self._port.lowstate_receiving():
            low = self._port.lowstate_age_s()
            if low is None or low > self._timeout_s:
                return False
        if mode is Mode.HIGH_LEVEL:
            sport_state = self._port.sport_state()
            return sport_state is not None and sport_state.age_s <= self._timeout_s
        return True
