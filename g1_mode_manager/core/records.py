"""What the mode machine hands out: call outcomes, the log of every attempt, and status snapshots."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from g1_mode_manager.core.modes import Mode


class Result(StrEnum):
    """How one attempt ended."""

    OK = "ok"  # the target mode was reached (for an e-stop: the robot was seen damped)
    REFUSED = "refused"  # not attempted: illegal pair, same mode, busy, or EMERGENCY
    FAILED = "failed"  # attempted and failed: the old mode is kept (an e-stop stays EMERGENCY)
    PREEMPTED = "preempted"  # cut short by an e-stop; no further robot call, mode not committed
    REGISTERED = "registered"  # an e-stop from a topic: EMERGENCY entered, the damping sequence runs on


@dataclass(frozen=True)
class Outcome:
    """The answer to request() or estop()."""

    success: bool
    mode: Mode  # the mode after the call
    message: str
    duration_s: float
    refused: bool  # True if nothing was attempted (success is then False)


@dataclass(frozen=True)
class TransitionRecord:
    """One attempt, accepted or refused, for the log and the history."""

    source: Mode
    target: Mode
    outcome: Result
    duration_s: float
    message: str


@dataclass(frozen=True)
class MachineStatus:
    """A consistent snapshot for the node's ~/mode topic (fields as in g1_mode_manager_msgs/Mode)."""

    mode: Mode
    transition_in_progress: bool
    transition_target: Mode | None  # None when no transition is in progress
    service_known: bool  # the last thing learnt about the high-level service is still valid
    service_active: bool  # ... and it said: active (meaningful only if service_known)
    damp_confirmed: bool  # the robot itself was seen damping with the service active (CheckMode + GetFsmId)
    last_refusal: str  # why the last refused or failed request did not happen ("" if none)
    last_error: str  # the last robot-side error ("" if none)
    robot_mismatch: str = ""  # why the robot no longer matches the mode (forwarding stopped); "" if it does
    reasserts: int = 0  # how often supervision had to re-damp the robot in EMERGENCY
    version: int = 0  # grows with every change: a snapshot with a lower version is older
    faults: tuple[str, ...] = ()  # FAULT: the body checks that put the robot there
    holds: tuple[str, ...] = ()  # body checks holding motion in the current mode
