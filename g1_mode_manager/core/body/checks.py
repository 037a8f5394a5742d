"""The robot's body checks as data: what each reads, its threshold, its debounce, and what it does in
each mode.

The thresholds are the ones Unitree's own C++ SDK gives a G1 program (``terminations.hpp``), the
debounces are short enough that a LOW_LEVEL controller's robot is damped within tens of milliseconds.
Reactions: WARN (diagnostics only), HOLD (no new motion, the mode is kept: StopMove, arm weight ramped
out, user lowcmd replaced by damping frames) and FAULT (the FAULT mode: damped like an e-stop, left only
by clear_fault). HOLD and FAULT latch until an operator clears them; WARN follows the condition.

A fall is a tilt (or spin) past the limit **while something is meant to hold the robot upright**: in
LOW_LEVEL always (the user's controller is responsible), in IDLE and HIGH_LEVEL only while the high-level
service is active in a state of the built-in controller that holds the robot up (``UPRIGHT_FSM_IDS``).
A robot the controller was told to let down or lay down (damp, zero torque, squat, sit) is not fallen by
this check, and a lying robot can be stood up through 702 without tripping it: 702 is exempt only while its
get-up runs (fsm_mode 1); once the robot stands at 702 (fsm_mode 0), a tilt is a fall again.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntEnum
from types import MappingProxyType
from typing import Final

from g1_mode_manager.core.modes import Mode
from g1_mode_manager.protocol.fsm import FsmId, FsmMode


class Reaction(IntEnum):
    """Ordered by severity."""

    NONE = 0
    WARN = 1
    HOLD = 2
    FAULT = 3


#: Controller states that hold the robot upright: lock stand, walking, squat-to-stand, running.
UPRIGHT_FSM_IDS: Final = frozenset({FsmId.STAND_UP, FsmId.WALK_OLD, FsmId.START, FsmId.START_WAIST,
                                    FsmId.SQUAT_TO_STAND, FsmId.RUN, FsmId.RUN_29DOF})


def holds_upright(fsm_id: int, fsm_mode: int) -> bool:
    """The built-in controller holds the robot upright: a standing or walking state, or lie-to-stand (702)
    once its get-up finished (while it runs the robot rises from the floor, tilted by design)."""
    return fsm_id in UPRIGHT_FSM_IDS or (fsm_id == FsmId.LIE_TO_STAND and fsm_mode == FsmMode.STATIC)


@dataclass(frozen=True)
class Check:
    """One body check. ``reading`` names a field of BodyReadings; it trips when the reading is above the
    threshold (``above``) or below it, continuously for ``debounce_s``."""

    name: str
    reading: str
    unit: str
    above: bool
    threshold: float
    debounce_s: float
    reactions: Mapping[Mode, Reaction]
    upright_only: bool  # counts only while something is meant to hold the robot upright
    reference: str  # what it follows
    #: a BodyReadings field whose text the check's own adds (its words on what it judged), or ""
    detail: str = ""

    def reaction(self, mode: Mode) -> Reaction:
        return self.reactions.get(mode, Reaction.NONE)

    def trips(self, value: float, threshold: float | None = None) -> bool:
        limit = self.threshold if threshold is None else threshold
        return value > limit if self.above else value < limit


def _per_mode(idle: Reaction, high: Reaction, low: Reaction) -> Mapping[Mode, Reaction]:
    return MappingProxyType({Mode.IDLE: idle, Mode.HIGH_LEVEL: high, Mode.LOW_LEVEL: low})


_W, _H, _F = Reaction.WARN, Reaction.HOLD, Reaction.FAULT
_VENDOR = "Unitree unitree_sdk2 g1/common/terminations.hpp"

CHECKS: tuple[Check, ...] = (
    Check("tilt", "tilt_rad", "rad", True, 1.0, 0.01, _per_mode(_F, _F, _F), True,
          f"{_VENDOR} bad_orientation: body z more than 1.0 rad from vertical"),
    Check("spin", "gyro_judged", "rad/s", True, 6.0, 0.01, _per_mode(_F, _F, _F), True,
          f"{_VENDOR} ang_vel_out_of_limit: any gyro axis above 6 rad/s (while a motion plays, above what it turns "
          "the body at, plus a margin: core/body/motion_allowance.py)"),
    Check("joint_speed", "joint_speed_judged", "rad/s", True, 10.0, 0.01, _per_mode(_W, _W, _F), True,
          f"{_VENDOR} joint_vel_out_of_limit: any |dq| above 10 rad/s (while a motion plays, above what it asks of "
          "the joint, plus a margin; never above the joint's URDF velocity limit: core/body/motion_allowance.py)",
          detail="joint_speed_detail"),
    Check("winding_overheat", "winding_max_c", "°C", True, 120.0, 0.0, _per_mode(_W, _H, _F), False,
          f"{_VENDOR} motor_winding_overheat: temperature[1] above 120 °C"),
    Check("casing_overheat", "casing_max_c", "°C", True, 85.0, 0.0, _per_mode(_W, _H, _F), False,
          f"{_VENDOR} motor_casing_overheat: temperature[0] above 85 °C"),
    Check("winding_critical", "winding_max_c", "°C", True, 135.0, 0.0, _per_mode(_F, _F, _F), False,
          "this project: past the vendor's limit a held HIGH_LEVEL robot is damped too"),
    Check("casing_critical", "casing_max_c", "°C", True, 95.0, 0.0, _per_mode(_F, _F, _F), False,
          "this project: past the vendor's limit a held HIGH_LEVEL robot is damped too"),
    Check("battery_low", "soc_pct", "%", False, 20.0, 2.0, _per_mode(_W, _W, _W), False,
          f"{_VENDOR} low_battery: BmsState_ soc below 20 %"),
    Check("battery_critical", "soc_pct", "%", False, 10.0, 2.0, _per_mode(_W, _H, _H), False,
          "this project: below it no new motion starts"),
    Check("state_lost", "state_age_s", "s", True, 1.0, 0.0, _per_mode(_W, _W, _F), False,
          f"{_VENDOR} lost_connection: no LowState_ for 1000 ms"),
)

BY_NAME: Final = MappingProxyType({c.name: c for c in CHECKS})
